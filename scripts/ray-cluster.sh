#!/bin/sh
# A Ray cluster for `noisybolt sweep --backend ray` over several machines.
#
#   scripts/ray-cluster.sh head  [PORT]        on the first machine (default port 6379)
#   scripts/ray-cluster.sh worker HEAD:PORT    on every other machine
#   scripts/ray-cluster.sh sweep CONFIG OUT [noisybolt sweep options]
#                                               on any machine of the cluster
#   scripts/ray-cluster.sh stop                on each machine, when done
#
# Every machine needs the same noisybolt installed (make setup) and the same path for
# OUT: run directories, checkpoints and Tune's experiment state are written there by
# whichever node runs a trial, so OUT must be on storage all nodes share (NFS or alike).
# Each trial trains on one torch thread (resources: {cpus: N} in the sweep reserves more).
# Running the same sweep command again resumes it (Tuner.restore, finished trials kept).
set -eu
VENV=${VENV:-.venv}
RAY="$VENV/bin/ray"
case "${1:-}" in
  head)
    "$RAY" start --head --port "${2:-6379}" --include-dashboard=false
    echo "workers join with: scripts/ray-cluster.sh worker $(hostname -I | cut -d' ' -f1):${2:-6379}"
    ;;
  worker)
    "$RAY" start --address "${2:?give the head's HOST:PORT}"
    ;;
  sweep)
    config=${2:?give the sweep config}; out=${3:?give the shared output directory}
    shift 3
    "$VENV/bin/noisybolt" sweep "$config" --backend ray --address auto --out "$out" "$@"
    ;;
  stop)
    "$RAY" stop
    ;;
  *)
    sed -n '2,15p' "$0"; exit 2
    ;;
esac
