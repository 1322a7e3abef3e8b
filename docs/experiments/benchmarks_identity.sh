#!/bin/bash
# The identity check of docs/experiments/2026-11-28-benchmarks-identity.md: every stage kind the
# benchmarks package touches, run outside DVC in worktree $1 (code before or after) into $2.
#   phase 1: benchmarks_identity.sh run WORKTREE OUT
#   phase 2: benchmarks_identity.sh assemble OLD_WORKTREE OLD_OUT PREDICTIONS  (once, old code)
#            benchmarks_identity.sh score WORKTREE OUT PREDICTIONS
#   phase 3: benchmarks_identity.sh ynet WORKTREE OUT
# Each worktree's params.yaml: short_term_models.cpu.epochs sgan {sdd: 2, ethucy: 1}, ynet
# {sdd: 32, ethucy: 1}; data/ links to a checkout's data/{short_term,raw,horizon_windows,windows,
# labels,ind}; checkpoints/pecnet_tf5 a trained PECNet; PREDICTIONS/long_term/tf<H>/ the stored
# long-term predictions of a make repro. Compare: identity_compare.py OLD_OUT NEW_OUT.
set -x
PY=${PY:-python}
LOW_MEMORY="env GLIBC_TUNABLES=glibc.malloc.mmap_threshold=4294967296:glibc.malloc.trim_threshold=17179869184"
phase=$1; W=$2; O=$3; P=$4
mkdir -p $O; cd $W
t() { local s=$(date +%s); "$@"; echo "rc=$? $(( $(date +%s)-s )) s: $*" >> $O/times.txt; }
case $phase in
run)
  t $PY -m pipeline.stages.short_term_windows --trajnet-sdd data/raw/trajnet-sdd --sgan data/raw/sgan --ynet-release data/raw/ynet-release --ethucy-scenes data/raw/ethucy-scenes --out $O/short_term --stats $O/short_term_windows.json
  t $PY -m pipeline.stages.ind_windows --out $O/ind --metrics $O/ind_windows.json
  for ds in sdd zara1; do
    t $PY -m pipeline.stages.train_short_term_baseline --dataset $ds --model sgan --windows data/short_term --checkpoint-dir $O/ckpt/${ds}_sgan --metrics $O/train_${ds}_sgan.json
    t $PY -m pipeline.stages.evaluate_short_term_baseline --dataset $ds --model sgan --windows data/short_term --checkpoint-dir $O/ckpt/${ds}_sgan --train-metrics $O/train_${ds}_sgan.json --metrics $O/run_${ds}_sgan.json --predictions $O/pred_${ds}_sgan.parquet
  done
  t $PY -m pipeline.stages.evaluate_baseline --model pecnet --horizon 5 --table data/horizon_windows/tf5.parquet --checkpoint-dir checkpoints/pecnet_tf5 --metrics $O/pecnet_tf5.json --predictions $O/pred_pecnet_tf5.parquet
  t $PY -m pipeline.stages.fit_model --model constant_velocity --horizon 5 --table data/horizon_windows/tf5.parquet --workdir $O/cv_tf5
  t $PY -m pipeline.stages.predict_model --model constant_velocity --horizon 5 --table data/horizon_windows/tf5.parquet --workdir $O/cv_tf5 --metrics $O/cv_tf5.json --predictions $O/pred_cv_tf5.parquet
  ;;
assemble)  # with the old code: the release table's constant velocity, inD's and the short-term files
  mkdir -p $P/long_term/release_tf30
  t $PY -m pipeline.stages.fit_model --model constant_velocity --horizon 30 --table data/windows/release_tf30.parquet --workdir $O/cv_release
  t $PY -m pipeline.stages.predict_model --model constant_velocity --horizon 30 --table data/windows/release_tf30.parquet --workdir $O/cv_release --metrics $O/cv_release.json --predictions $P/long_term/release_tf30/constant_velocity.parquet
  PYTHONPATH=$W $PY - "$O" "$P" <<'PYTHON'
import shutil, sys
from pathlib import Path
from pipeline.harness.predictions import write_no_predictions
from pipeline.runners import ind as ind_runner
from pipeline.runners.short_term import prediction_metadata  # the code before the change
out, predictions = Path(sys.argv[1]), Path(sys.argv[2])
ind_runner.write_predictions(predictions / "ind", {}, not_provided="inD not provided (identity check)")
for dataset in ("sdd", "eth", "hotel", "univ", "zara1", "zara2"):
    folder = predictions / "short_term" / dataset
    folder.mkdir(parents=True)
    scored = out / f"pred_{dataset}_sgan.parquet"
    if scored.exists():
        shutil.copy(scored, folder / "sgan.parquet")
    else:
        write_no_predictions(folder / "sgan.parquet", prediction_metadata(
            Path("data/short_term"), dataset, "sgan"), "not trained (identity check)")
PYTHON
  ;;
score)
  t $PY -m pipeline.stages.score_predictions --predictions $P/long_term --horizon-windows data/horizon_windows --release-windows data/windows/release_tf30.parquet --labels data/labels --scales data/raw/sdd/estimated_scales.yaml --ind data/ind --ind-predictions $P/ind --out $O/score/beyond_long_term.json --ind-out $O/score/beyond_ind.json
  t $PY -m pipeline.stages.score_short_term_predictions --predictions $P/short_term --windows data/short_term --labels data/labels --scales data/raw/sdd/estimated_scales.yaml --out $O/score/beyond_short_term.json
  ;;
ynet)
  t $LOW_MEMORY $PY -m pipeline.stages.train_short_term_ynet --dataset eth --windows data/short_term --maps data/short_term/ethucy_semantic --sdd data/raw/sdd --checkpoint-dir $O/ynet/ckpt/eth_ynet --metrics $O/ynet/train_eth_ynet.json
  t $LOW_MEMORY $PY -m pipeline.stages.evaluate_short_term_ynet --dataset eth --windows data/short_term --maps data/short_term/ethucy_semantic --sdd data/raw/sdd --ethucy-scenes data/raw/ethucy-scenes --checkpoint-dir $O/ynet/ckpt/eth_ynet --train-metrics $O/ynet/train_eth_ynet.json --metrics $O/ynet/run_eth_ynet.json --predictions $O/ynet/pred_eth_ynet.parquet --qualitative $O/ynet/qual_eth_ynet.npz
  ;;
esac
