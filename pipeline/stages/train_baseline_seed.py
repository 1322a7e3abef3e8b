"""Stage `train_baseline_seed@<model>-<t_f>-<seed>`: train one baseline (S-GAN or PECNet) for one
horizon again with an extra training seed (`baseline_seeds.extra`), to measure how far training
alone moves the metrics.

Exactly `train_baseline` (`pipeline.runners.baseline_runs.train_record`) with `--seed` in place of
`train_baseline.seed`: the seed sets the initial weights, the batch order, the training noise and
latents, and the validation draws that select the epoch. The JSON of training facts also holds the
validation curve (`val_ade_per_epoch`: the kept epoch is its minimum), so that a later change of
epoch selection can be judged on every seed. Resumable and preemptible as `train_baseline`.
Params: `train_baseline.threads`, `<model>.<profile>`, `profile`, `windows.n_past`, `runtime.device`,
`runtime.max_minutes`.

    python -m pipeline.stages.train_baseline_seed --model pecnet --horizon 30 --seed 1 \
        --table data/horizon_windows/tf30.parquet --checkpoint-dir checkpoints/seeds/pecnet_tf30_seed1 \
        --metrics metrics/baselines/seeds/train_pecnet_tf30_seed1.json
"""

from __future__ import annotations

from pipeline.config.loading import active_profile, load_profile, load_section, read_params
from pipeline.config.runtime import RuntimeParams
from pipeline.config.train_baseline import TrainBaselineParams
from pipeline.config.windows import WindowParams
from pipeline.runners.baseline_runs import (BaselineTraining, run_arguments, train_record,
                                           validation_curve)
from pipeline.runners.baselines import config_class
from pipeline.io import write_json
from pipeline.preemption import exit_when_stopped


@exit_when_stopped
def main(argv: list[str] | None = None) -> None:
    parser = run_arguments(__doc__.splitlines()[0], "model folder (best.pt, last.pt)")
    parser.add_argument("--seed", type=int, required=True, help="training seed (one of baseline_seeds.extra)")
    args = parser.parse_args(argv)
    params = read_params()
    training = BaselineTraining(
        active_profile(params), load_profile(config_class(args.model), args.model, params),
        load_section(TrainBaselineParams, "train_baseline", params),
        load_section(WindowParams, "windows", params).n_past,
        load_section(RuntimeParams, "runtime", params))
    record = train_record(args.model, args.horizon, args.table, args.checkpoint_dir, training,
                          seed=args.seed)
    write_json({**record, "val_ade_per_epoch": validation_curve(args.checkpoint_dir)}, args.metrics)


if __name__ == "__main__":
    main()
