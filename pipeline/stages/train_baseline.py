"""Stage `train_baseline@<model>-<t_f>`: train one baseline (S-GAN or PECNet) for one horizon.

Trains on the window table's `train` split, keeps the epoch with the lowest min-over-K ADE on its
`val` split (never `test`; `pipeline.runners.baseline_runs.train_record`), and writes the
checkpoint folder (`best.pt`, `last.pt`; an interrupted run resumes from `last.pt`) and a JSON of
training facts.
SIGTERM / SIGINT or `runtime.max_minutes` save a mid-epoch checkpoint and exit 143 / 130 / 75.
Params: `train_baseline` (seed, threads), `<model>.<profile>`, `profile`, `windows.n_past`,
`runtime.device`, `runtime.max_minutes`.

    python -m pipeline.stages.train_baseline --model pecnet --horizon 30 \
        --table data/horizon_windows/tf30.parquet --checkpoint-dir checkpoints/pecnet_tf30 \
        --metrics metrics/baselines/train_pecnet_tf30.json
"""

from __future__ import annotations

from pipeline.config.loading import active_profile, load_profile, load_section, read_params
from pipeline.config.runtime import RuntimeParams
from pipeline.config.train_baseline import TrainBaselineParams
from pipeline.config.windows import WindowParams
from pipeline.runners.baseline_runs import BaselineTraining, run_arguments, train_record
from pipeline.runners.baselines import config_class
from pipeline.io import write_json
from pipeline.preemption import exit_when_stopped


@exit_when_stopped
def main(argv: list[str] | None = None) -> None:
    args = run_arguments(__doc__.splitlines()[0], "model folder (best.pt, last.pt)").parse_args(argv)
    params = read_params()
    training = BaselineTraining(
        active_profile(params), load_profile(config_class(args.model), args.model, params),
        load_section(TrainBaselineParams, "train_baseline", params),
        load_section(WindowParams, "windows", params).n_past,
        load_section(RuntimeParams, "runtime", params))
    record = train_record(args.model, args.horizon, args.table, args.checkpoint_dir, training)
    write_json(record, args.metrics)


if __name__ == "__main__":
    main()
