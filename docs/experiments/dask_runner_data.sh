#!/bin/bash
# Data stages forced with the runner before (44fff97) and after (Dask): wall seconds and whether
# every output hash in dvc.lock equals the committed one. Runs in /work/wt-bench, a worktree of
# the commit under test; usage: dask_runner_data.sh [LOG_FOLDER] [ROUNDS].
LOGS=${1:-/work/runs/daskbench}
ROUNDS=${2:-1}
mkdir -p "$LOGS"
cd /work/wt-bench
export PATH=/work/wt-bench/.venv/bin:$PATH
STAGES="tracks windows horizon_windows chain_bias audit"
for round in $(seq "$ROUNDS"); do
for side in new old; do
  git checkout -q HEAD -- tools/ dvc.lock
  [ $side = old ] && git checkout -q 44fff97 -- tools/parallel_repro.py tools/timed_repro.py && rm -f tools/stage_worker.py
  start=$(date +%s.%N)
  python -m tools.timed_repro --jobs 2 -f -s $STAGES > "$LOGS/data-$side-$round.log" 2>&1
  rc=$?
  end=$(date +%s.%N)
  same=$(python3 -c "
import yaml, subprocess
now = yaml.safe_load(open('dvc.lock'))['stages']
committed = yaml.safe_load(subprocess.run(['git', 'show', 'HEAD:dvc.lock'], capture_output=True, text=True).stdout)['stages']
print(all(now[s]['outs'] == committed[s]['outs'] for s in '$STAGES'.split()))")
  echo "data $side round $round rc=$rc wall=$(python3 -c "print(round($end-$start,1))") outs_as_committed=$same" >> "$LOGS/times.txt"
done
done
git checkout -q HEAD -- tools/ dvc.lock
