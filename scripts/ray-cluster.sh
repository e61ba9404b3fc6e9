#!/bin/sh
# A Ray cluster for `noisybolt sweep --backend ray` over several machines.
#
#   scripts/ray-cluster.sh head [PORT [ray start options]]   on the first machine (port 6379)
#   scripts/ray-cluster.sh worker HEAD:PORT                 on every other machine
#   scripts/ray-cluster.sh sweep CONFIG OUT [noisybolt sweep options]
#                                                           on any machine of the cluster
#   scripts/ray-cluster.sh stop                             on each machine, when done
#
# Every machine needs the same noisybolt installed (make setup) and OUT at the same path:
# run directories, checkpoints and Tune's experiment state (OUT/ray/) are written there by
# whichever node runs a trial, so OUT must be on storage all nodes share (NFS or alike).
# `sweep` joins the cluster at $RAY_ADDRESS (default: auto, the one started on this
# machine); running the same command again resumes the sweep. `stop` is `ray stop`: it
# stops every Ray process of this user on the machine. tests/experiments/test_ray_cluster.py
# runs head (--num-cpus 2 --temp-dir DIR --block) and sweep on one machine.
#
# Token authentication: `ray start` (Ray 2.60) turns it on when a token exists
# (~/.ray/auth_token, $RAY_AUTH_TOKEN_PATH or $RAY_AUTH_TOKEN; a local ray.init() writes
# one), but a driver joining with --address does not, and is refused. So every command
# here turns it on likewise; on several machines, give every node the same token.
set -eu
VENV=${VENV:-.venv}
if [ -z "${RAY_AUTH_MODE:-}" ] && { [ -n "${RAY_AUTH_TOKEN:-}" ] ||
    [ -f "${RAY_AUTH_TOKEN_PATH:-${HOME:-~}/.ray/auth_token}" ]; }; then
  export RAY_AUTH_MODE=token
fi
case "${1:-}" in
  head)
    port=${2:-6379}
    [ $# -ge 2 ] && shift 2 || shift $#
    echo "workers join with: scripts/ray-cluster.sh worker $(hostname -I | cut -d' ' -f1):$port"
    exec "$VENV/bin/ray" start --head --port "$port" --include-dashboard=false "$@"
    ;;
  worker)
    exec "$VENV/bin/ray" start --address "${2:?give the head HOST:PORT}"
    ;;
  sweep)
    config=${2:?give the sweep config}; out=${3:?give the shared output directory}
    shift 3
    exec "$VENV/bin/noisybolt" sweep "$config" --backend ray --address "${RAY_ADDRESS:-auto}" \
      --out "$out" "$@"
    ;;
  stop)
    exec "$VENV/bin/ray" stop
    ;;
  *)
    sed -n '2,21p' "$0"; exit 2
    ;;
esac
