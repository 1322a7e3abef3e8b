"""Stage `semantic_maps`: the per-class probability map of every video, in the form Y-net consumes.

`semantic.source: predicted` runs the trained U-Net over each whole scene, `labels` turns the hand
labels into one-hot maps (the oracle ablation); the maps are scored against the hand labels on the
test videos (IoU, mIoU) and drawn (`pipeline.runners.semantic_maps`). Params: `semantic`,
`runtime.device`.

    python -m pipeline.stages.semantic_maps --sdd data/raw/sdd --labels data/labels \
        --model data/segmentation/model.pt --out data/semantic_maps \
        --metrics metrics/segmentation.json --figures reports/figures/segmentation/predictions
"""

from __future__ import annotations

import argparse
from pathlib import Path

from pipeline.config.loading import load_section, read_params
from pipeline.config.runtime import RuntimeParams
from pipeline.config.semantic import SemanticParams
from pipeline.device import SCORING, describe, select_device
from pipeline.io import exit_on_bad_intermediate
from pipeline.runners.semantic_maps import build_maps


@exit_on_bad_intermediate
def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sdd", type=Path, required=True, help="SDD root holding annotations/")
    parser.add_argument("--labels", type=Path, required=True, help="output folder of stage labels")
    parser.add_argument("--model", type=Path, required=True, help="trained U-Net (stage segmentation)")
    parser.add_argument("--out", type=Path, required=True, help="folder for maps.npz + index.json")
    parser.add_argument("--metrics", type=Path, required=True, help="IoU metrics JSON to write")
    parser.add_argument("--figures", type=Path, required=True, help="folder for test-video figures")
    args = parser.parse_args(argv)
    raw = read_params()
    params = load_section(SemanticParams, "semantic", raw)
    runtime = load_section(RuntimeParams, "runtime", raw)
    device = select_device(runtime.device, purpose=SCORING)
    print(f"semantic_maps: source {params.source}, on {describe(device)}")
    metrics = build_maps(args.sdd, args.labels, args.model, args.out, args.metrics, args.figures,
                         params, device)
    print(f"semantic_maps ({params.source}): test mIoU {metrics['miou']} over "
          f"{metrics['test_videos']} videos; IoU {metrics['iou']}")


if __name__ == "__main__":
    main()
