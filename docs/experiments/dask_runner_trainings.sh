#!/bin/bash
# make repro's runner before (44fff97, home-made loop) and after (Dask): the same 4 forced
# single-threaded stages, 2 at once, alternated; wall seconds, the driver process's own CPU seconds
# (/proc/<pid>/stat, its children not counted) and the stages' dvc.lock entries.
# Runs in /work/wt-bench, a worktree of the commit under test;
# usage: dask_runner_trainings.sh [LOG_FOLDER] [ROUNDS].
LOGS=${1:-/work/runs/daskbench}
ROUNDS=${2:-2}
mkdir -p "$LOGS"
cd /work/wt-bench
export PATH=/work/wt-bench/.venv/bin:$PATH
STAGES="train_baseline@sgan-40 train_baseline@sgan-50 train_baseline@pecnet-40 train_baseline@pecnet-50"
for round in $(seq "$ROUNDS"); do
  for side in new old; do
    git checkout -q HEAD -- tools/
    [ $side = old ] && git checkout -q 44fff97 -- tools/parallel_repro.py tools/timed_repro.py && rm -f tools/stage_worker.py
    while pgrep -f "pipeline.stages|timed_repro" > /dev/null; do sleep 1; done  # nothing beside
    rm -rf checkpoints/sgan_tf40 checkpoints/sgan_tf50 checkpoints/pecnet_tf40 checkpoints/pecnet_tf50
    start=$(date +%s.%N)
    python -m tools.timed_repro --jobs 2 -f -s $STAGES > "$LOGS"/$side-$round.log 2>&1 &
    driver=$! stat=""
    while kill -0 $driver 2> /dev/null; do stat=$(cat /proc/$driver/stat 2> /dev/null || echo "$stat"); sleep 0.5; done
    wait $driver
    rc=$?
    end=$(date +%s.%N)
    driver_cpu=$(echo "$stat" | awk '{print ($14 + $15) / 100}')
    python3 -c "
import yaml,json
lock=yaml.safe_load(open('dvc.lock'))['stages']
print(json.dumps({s: [o['md5'] for o in lock[s]['outs']] for s in '$STAGES'.split()}))" > "$LOGS"/$side-$round.lock.json
    echo "$side round $round rc=$rc wall=$(python3 -c "print(round($end-$start,1))") driver_cpu_s=$driver_cpu" >> "$LOGS"/times.txt
    git checkout -q HEAD -- tools/ dvc.lock
  done
done
echo done >> "$LOGS"/times.txt
