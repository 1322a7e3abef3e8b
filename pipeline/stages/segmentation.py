"""Stage `segmentation`: train the scene U-Net on the TRAIN videos' hand labels, from scratch.

The paper's recipe with two documented departures (`pipeline.runners.segmentation`): no pretrained
encoder, and a smaller `cpu` profile. Seeded; checkpointed every epoch and, on SIGTERM / SIGINT or
when `runtime.max_minutes` runs out, mid-epoch too (exit 143 / 130 / 75); the next run resumes to
the same weights. Params: `segmentation.<profile>`, `profile`, `runtime.device`, `runtime.max_minutes`.

    python -m pipeline.stages.segmentation --sdd data/raw/sdd --labels data/labels \
        --checkpoint data/segmentation/checkpoints/last.pt --model data/segmentation/model.pt \
        --log data/segmentation/train_log.csv
"""

from __future__ import annotations

import argparse
from pathlib import Path

import torch

from pipeline.config.loading import active_profile, load_profile, load_section, read_params
from pipeline.config.runtime import RuntimeParams
from pipeline.config.segmentation import SegmentationParams
from pipeline.data.labels import read_index
from pipeline.device import TRAINING, describe, select_device
from pipeline.io import exit_on_bad_intermediate
from pipeline.preemption import Preemption, exit_when_stopped
from pipeline.runners.segmentation import (export_model, fingerprint, load_training_scenes, train,
                                           write_log)


@exit_when_stopped
@exit_on_bad_intermediate
def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sdd", type=Path, required=True, help="SDD root holding annotations/")
    parser.add_argument("--labels", type=Path, required=True, help="output folder of stage labels")
    parser.add_argument("--checkpoint", type=Path, required=True,
                        help="per-epoch checkpoint (kept between runs to resume)")
    parser.add_argument("--model", type=Path, required=True, help="trained weights to write")
    parser.add_argument("--log", type=Path, required=True, help="per-epoch training log CSV")
    args = parser.parse_args(argv)
    raw = read_params()
    params = load_profile(SegmentationParams, "segmentation", raw)
    runtime = load_section(RuntimeParams, "runtime", raw)
    profile = active_profile(raw)
    torch.set_num_threads(params.threads)
    device = select_device(runtime.device, purpose=TRAINING)

    index = read_index(args.labels)
    names = sorted(n for n, v in index["videos"].items() if v["split"] == "train")
    if not names:
        raise SystemExit(f"segmentation: no train videos in {args.labels}/index.json")
    scenes = load_training_scenes(args.sdd, args.labels, names, params.downsample, params.pad_multiple)
    run_id = fingerprint(params, names, scenes)
    print(f"segmentation: profile {profile}, {len(names)} train videos, run {run_id}, "
          f"on {describe(device)}")
    with Preemption(runtime.max_minutes) as preemption:
        model, log = train(scenes, params, args.checkpoint, run_id, device=device,
                           preemption=preemption)
    export_model(args.model, model, params, profile, names, log)
    write_log(args.log, log)
    seconds = sum(row["seconds"] for row in log)
    print(f"segmentation: {len(log)} epochs, {sum(r['crops'] for r in log)} crops in {seconds:.0f} s, "
          f"final Dice loss {log[-1]['loss']:.4f}")


if __name__ == "__main__":
    main()
