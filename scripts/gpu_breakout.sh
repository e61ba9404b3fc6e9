#!/bin/sh
# Breakout image-agent runs on a lent GPU machine (issue 17), for a fixed wall-clock
# budget: each run trains until SECONDS_BUDGET, is stopped with SIGTERM (it saves a
# checkpoint), and its resume files are kept (scripts/breakout_runs.py keep) and packed
# into $OUT, one tarball per run, to unpack here into results/breakout/ and continue
# later (on the CPU too: algorithm.device may change on --resume).
#
# The GPU machine has no package registry: the packages its image lacks travel as wheels
# in .whl/ and the MONA binary in .mona/ (both git-ignored; see results/breakout/README.md),
# the bolt's classifiers and DFAs in .nbcache/ (trained here first, so the runs do not
# each train the same classifier there).
#
#   sh scripts/gpu_breakout.sh SECONDS_BUDGET RUN_NAME "TRAIN ARGS" [RUN_NAME "TRAIN ARGS" ...]
#   sh scripts/gpu_breakout.sh 400 breakout-img-ppo-gpu-settled-bolted-seed0 --resume ...
#
# A run kept in results/breakout is restored first (so "--resume" continues it on a fresh
# machine). Here, afterwards: tar -xzf FILES_AT/RUN.tar.gz -C results/breakout.
set -eu
budget=$1
shift
here=$(pwd)
if [ -d .whl ]; then
    python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade \
        --target /tmp/site .whl/*.whl
    export PYTHONPATH="/tmp/site:$here/src"
else
    export PYTHONPATH="$here/src"
fi
if [ -d .mona ]; then
    export PATH="$here/.mona:$PATH" LD_LIBRARY_PATH="$here/.mona:${LD_LIBRARY_PATH:-}"
fi
export NOISYBOLT_CACHE_DIR="$here/.nbcache" PYTHONUNBUFFERED=1
out=${OUT:-$here/runs/gpu-out}
mkdir -p "$out" runs
nvidia-smi --query-gpu=name,memory.total --format=csv,noheader || true
python3 -c 'import torch; print("torch", torch.__version__, "cuda", torch.cuda.is_available())'
names=""
while [ $# -ge 2 ]; do
    name=$1
    args=$2
    shift 2
    # a run kept in results/breakout (a later session, a fresh machine): put it back
    if [ ! -d "runs/$name" ] && [ -d "results/breakout/$name" ]; then
        python3 scripts/breakout_runs.py restore "$name"
    fi
    # shellcheck disable=SC2086  # the run's arguments are words
    (
        status=0
        timeout -s TERM -k 120 "$budget" python3 -m noisybolt train $args --no-progress \
            --out "runs/$name" || status=$?
        # 124: stopped by the budget (it saved a checkpoint); 130: interrupted otherwise;
        # 137 or a signal's 128+N: killed (what it trained since its checkpoint is lost)
        echo "gpu_breakout: $name ended with exit status $status at $(date +%T)"
    ) >"$out/$name.log" 2>&1 &
    names="$names $name"
done
wait || true
for name in $names; do
    tail -n 5 "$out/$name.log"
done
kept=""
for name in $names; do  # a run stopped before it began (its classifier) has nothing to keep
    if [ -f "runs/$name/checkpoints/latest.json" ]; then kept="$kept $name"; fi
done
if [ -n "$kept" ]; then
    python3 scripts/breakout_runs.py keep $(for n in $kept; do printf 'runs/%s ' "$n"; done)
fi
for name in $kept; do
    tar -czf "$out/$name.tar.gz" -C results/breakout "$name"
done
ls -la "$out"
