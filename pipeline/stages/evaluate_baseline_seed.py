"""Stage `evaluate_baseline_seed@<model>-<t_f>-<seed>`: score the S-GAN or PECNet of an extra
training seed (`train_baseline_seed`) exactly as `evaluate_baseline` scores the main one.

The same split, K, rounds and round seeds (`evaluate_baseline`), so that only training differs
between this record and `metrics/baselines/<model>_tf<H>.json`; the record adds `training_seed`
(read from the checkpoint). Test predictions are not stored. Params: `evaluate_baseline`,
`windows.n_past`, `runtime.device`.

    python -m pipeline.stages.evaluate_baseline_seed --model pecnet --horizon 30 \
        --table data/horizon_windows/tf30.parquet --checkpoint-dir checkpoints/seeds/pecnet_tf30_seed1 \
        --metrics metrics/baselines/seeds/pecnet_tf30_seed1.json
"""

from __future__ import annotations

from pipeline.config.evaluate_baseline import EvaluateBaselineParams
from pipeline.config.loading import load_section, read_params
from pipeline.config.runtime import RuntimeParams
from pipeline.config.windows import WindowParams
from pipeline.runners.baseline_runs import run_arguments, score_to_file, training_seed


def main(argv: list[str] | None = None) -> None:
    args = run_arguments(__doc__.splitlines()[0], "the extra seed's model").parse_args(argv)
    params = read_params()
    score_to_file(args.model, args.table, args.horizon, args.checkpoint_dir, args.metrics, None,
                  load_section(EvaluateBaselineParams, "evaluate_baseline", params),
                  load_section(WindowParams, "windows", params).n_past,
                  load_section(RuntimeParams, "runtime", params),
                  {"training_seed": training_seed(args.checkpoint_dir)})


if __name__ == "__main__":
    main()
