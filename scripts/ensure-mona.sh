#!/bin/sh
# Make sure the MONA binary (used to compile LTLf to DFAs) is on PATH.
# Installs it with apt-get when we are root on Debian/Ubuntu; otherwise says what to run.
set -e
if command -v mona >/dev/null 2>&1; then
  exit 0
fi
if [ "$(id -u)" = "0" ] && command -v apt-get >/dev/null 2>&1; then
  echo "MONA not found: installing it with apt-get (package 'mona')"
  DEBIAN_FRONTEND=noninteractive apt-get update -q >/dev/null
  DEBIAN_FRONTEND=noninteractive apt-get install -y -q mona >/dev/null
  command -v mona >/dev/null 2>&1 && exit 0
fi
echo "error: the MONA binary is missing. Install it with:" >&2
echo "    sudo apt-get install mona" >&2
echo "(noisybolt can compile without it through its pure-Python backend, but the tests check both.)" >&2
exit 1
