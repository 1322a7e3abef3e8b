#!/bin/bash
# Old (main) vs new (wt-models) code on the same inputs: long-term baseline scoring and training.
# Usage: edit the two roots (before / after) and CK (baseline checkpoints of a finished make repro), then run; compare with identity_compare.py OLD NEW.
set -u
HW=/work/main/data/horizon_windows
CK=/work/wt-clock/checkpoints
for side in old new; do
  root=/work/main; [ $side = new ] && root=/work/wt-models
  out=/work/runs/ident/$side; rm -rf $out; mkdir -p $out
  cd $root
  export PYTHONPATH=$root
  py="nice -n 15 /work/main/.venv/bin/python -m"
  $py pipeline.stages.evaluate_baseline --model sgan --horizon 30 --table $HW/tf30.parquet --checkpoint-dir $CK/sgan_tf30 --metrics $out/sgan_tf30.json --predictions $out/sgan_tf30.parquet
  $py pipeline.stages.evaluate_baseline --model pecnet --horizon 10 --table $HW/tf10.parquet --checkpoint-dir $CK/pecnet_tf10 --metrics $out/pecnet_tf10.json --predictions $out/pecnet_tf10.parquet
  $py pipeline.stages.evaluate_rpecnet --horizon 30 --table $HW/tf30.parquet --checkpoint-dir $CK/pecnet_tf5 --metrics $out/rpecnet_tf30.json --predictions $out/rpecnet_tf30.parquet
  $py pipeline.stages.evaluate_pecnet_ka --table $HW/tf30.parquet --checkpoint-dir $CK/pecnet_tf30 --metrics $out/pecnet_ka.json
  $py pipeline.stages.predict_model --model constant_velocity --horizon 30 --table $HW/tf30.parquet --workdir /work/main/checkpoints/models/constant_velocity_tf30 --metrics $out/cv_tf30.json --predictions $out/cv_tf30.parquet
  $py pipeline.stages.train_baseline --model sgan --horizon 60 --table $HW/tf60.parquet --checkpoint-dir $out/ck/sgan_tf60 --metrics $out/train_sgan_tf60.json
  $py pipeline.stages.train_baseline --model pecnet --horizon 60 --table $HW/tf60.parquet --checkpoint-dir $out/ck/pecnet_tf60 --metrics $out/train_pecnet_tf60.json
done > /work/runs/ident/log 2>&1
echo done > /work/runs/ident/finished
