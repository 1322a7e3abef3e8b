#!/bin/bash
# Byte identity of the benchmarks refactor: run each touched stage kind in worktree $1 into $2.
set -x
W=$1; O=$2; mkdir -p $O
cd $W
PY=/work/main/.venv/bin/python
export PYTHONHASHSEED=0
t() { local s=$(date +%s); "$@"; echo "rc=$? $(( $(date +%s)-s )) s: $*" >> $O/times.txt; }
t $PY -m pipeline.stages.short_term_windows --trajnet-sdd data/raw/trajnet-sdd --sgan data/raw/sgan --ynet-release data/raw/ynet-release --ethucy-scenes data/raw/ethucy-scenes --out $O/short_term --stats $O/short_term_windows.json
t $PY -m pipeline.stages.ind_windows --out $O/ind --metrics $O/ind_windows.json
t $PY -m pipeline.stages.score_predictions --predictions data/predictions/long_term --horizon-windows data/horizon_windows --release-windows data/windows/release_tf30.parquet --labels data/labels --scales data/raw/sdd/estimated_scales.yaml --ind data/ind --ind-predictions data/predictions/ind --out $O/beyond_long_term.json --ind-out $O/beyond_ind.json
t $PY -m pipeline.stages.score_short_term_predictions --predictions data/predictions/short_term --windows data/short_term --labels data/labels --scales data/raw/sdd/estimated_scales.yaml --out $O/beyond_short_term.json
for ds in sdd zara1; do
  t $PY -m pipeline.stages.train_short_term_baseline --dataset $ds --model sgan --windows data/short_term --checkpoint-dir $O/ckpt/${ds}_sgan --metrics $O/train_${ds}_sgan.json
  t $PY -m pipeline.stages.evaluate_short_term_baseline --dataset $ds --model sgan --windows data/short_term --checkpoint-dir $O/ckpt/${ds}_sgan --train-metrics $O/train_${ds}_sgan.json --metrics $O/run_${ds}_sgan.json --predictions $O/pred_${ds}_sgan.parquet
done
t $PY -m pipeline.stages.evaluate_baseline --model pecnet --horizon 5 --table data/horizon_windows/tf5.parquet --checkpoint-dir checkpoints/pecnet_tf5 --metrics $O/pecnet_tf5.json --predictions $O/pred_pecnet_tf5.parquet
t $PY -m pipeline.stages.fit_model --model constant_velocity --horizon 5 --table data/horizon_windows/tf5.parquet --workdir $O/cv_tf5
t $PY -m pipeline.stages.predict_model --model constant_velocity --horizon 5 --table data/horizon_windows/tf5.parquet --workdir $O/cv_tf5 --metrics $O/cv_tf5.json --predictions $O/pred_cv_tf5.parquet
echo done >> $O/times.txt
