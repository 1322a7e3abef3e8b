"""Stage `train_ind`: everything the inD benchmark trains (paper Tables 3/4).

On the `ind_windows` output: the SDD U-Net fine-tuned on labelled inD backgrounds when there are
any, and the semantic maps of every background; Y-net (`ynet.<profile>` at inD's `ynet_resize`);
S-GAN and PECNet at t_f = 30 and PECNet at t_f = 5 (R-PECNet's)
(`pipeline.runners.long_term_training` on `pipeline.benchmarks.ind.IND`). Writes
the checkpoint folder (resumable; SIGTERM / SIGINT or `runtime.max_minutes` checkpoint and exit
143 / 130 / 75) and the training record; inD not provided: the not-provided record, at once.
Params: `profile`, `runtime.device`, `runtime.max_minutes`, `ind_benchmark.<profile>`,
`ynet.<profile>`, `segmentation.<profile>`, `sgan.<profile>`, `pecnet.<profile>`, `train_baseline`.

    python -m pipeline.stages.train_ind --ind data/ind --segmentation-model data/segmentation/model.pt \
        --checkpoint-dir checkpoints/ind --metrics metrics/ind_train.json
"""

from __future__ import annotations

import argparse
from pathlib import Path

from pipeline.benchmarks.ind import IND, at_ind_scale
from pipeline.config.ind_benchmark import IndBenchmarkParams
from pipeline.config.loading import active_profile, load_profile, load_section, read_params
from pipeline.config.runtime import RuntimeParams
from pipeline.config.segmentation import SegmentationParams
from pipeline.config.train_baseline import TrainBaselineParams
from pipeline.config.ynet import YnetSettings
from pipeline.device import TRAINING, describe, select_device
from pipeline.io import exit_on_bad_intermediate, write_json
from pipeline.preemption import Preemption, exit_when_stopped
from pipeline.model_list import TRAINED_BASELINES
from pipeline.runners.baselines import config_class
from pipeline.runners.long_term_training import TrainSettings, train_benchmark


@exit_when_stopped
@exit_on_bad_intermediate
def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ind", type=Path, required=True, help="output folder of stage ind_windows")
    parser.add_argument("--segmentation-model", type=Path, required=True,
                        help="the SDD-trained U-Net (stage segmentation)")
    parser.add_argument("--checkpoint-dir", type=Path, required=True)
    parser.add_argument("--metrics", type=Path, required=True, help="training record (JSON)")
    args = parser.parse_args(argv)
    params = read_params()
    ind = load_profile(IndBenchmarkParams, "ind_benchmark", params)
    ynet, segmentation = at_ind_scale(ind, load_profile(YnetSettings, "ynet", params),
                                      load_profile(SegmentationParams, "segmentation", params))
    settings = TrainSettings(
        profile=active_profile(params), ynet=ynet, segmentation=segmentation,
        freeze_encoder_epochs=ind.freeze_encoder_epochs,
        baseline_configs={m: load_profile(config_class(m), m, params) for m in TRAINED_BASELINES},
        train_baseline=load_section(TrainBaselineParams, "train_baseline", params),
        runtime=load_section(RuntimeParams, "runtime", params))
    device = select_device(settings.runtime.device, purpose=TRAINING)
    print(f"train_ind: on {describe(device)}")
    with Preemption(settings.runtime.max_minutes) as preemption:
        record = train_benchmark(IND, args.ind, args.segmentation_model, args.checkpoint_dir,
                                 settings, device, preemption)
    write_json(record, args.metrics, sort_keys=True)
    if not record["provided"]:
        print(f"train_ind: inD not provided: {record['reason']}")


if __name__ == "__main__":
    main()
