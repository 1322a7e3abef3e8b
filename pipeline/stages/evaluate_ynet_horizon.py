"""Stage `evaluate_ynet_horizon@<t_f>`: Y-net scored at one prediction horizon (paper Figure 4).

Loads the best epoch of `train_ynet_horizon` (its settings from the checkpoint) and scores it on
the horizon table's test windows: TTST + CWS, K_e from `eval.<profile>`, K_a = 1, over
`ynet_horizons.<profile>.rounds` seeded rounds, as `ynet_slot_scoring` resolved them into
`--scoring` (a dep instead of those params: a horizon the profile does not train is not re-run by a
sampling change). Writes {t_f, profile, trained, n_windows, rounds, waypoints, main, eval_seconds,
<training summary>} and every round's test predictions (paths and sampled goals in original pixels,
`pipeline.harness.predictions`); a horizon that was not trained gets the training stage's not-run
record and an empty predictions file that gives the same reason. Params: `runtime.device`,
`windows.n_past`.

    python -m pipeline.stages.evaluate_ynet_horizon --horizon 10 \
        --table data/horizon_windows/tf10.parquet --semantic-maps data/semantic_maps \
        --sdd data/raw/sdd --checkpoint-dir checkpoints/ynet_tf10 \
        --scoring data/ynet_slot_scoring/tf10.json --train-metrics metrics/ynet_horizons/train_tf10.json \
        --metrics metrics/ynet_horizons/tf10.json \
        --predictions data/predictions/long_term/tf10/ynet.parquet
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from pipeline.benchmarks.sdd_long_term import SDD_LONG_TERM
from pipeline.config.loading import load_section, read_params
from pipeline.config.runtime import RuntimeParams
from pipeline.config.windows import WindowParams
from pipeline.harness.predictions import PredictionRounds, write_no_predictions
from pipeline.io import exit_on_bad_intermediate, write_json
from pipeline.model_list import YNET
from pipeline.runners.ynet_horizon import horizon_splits, training_summary
from pipeline.runners.slot_scoring import SlotScoring, check_agrees, horizon_slot, read_slot_scoring


@exit_on_bad_intermediate
def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--horizon", type=int, required=True, help="t_f in seconds")
    parser.add_argument("--table", type=Path, required=True, help="horizon window table (parquet)")
    parser.add_argument("--semantic-maps", type=Path, required=True)
    parser.add_argument("--sdd", type=Path, required=True, help="fetched SDD root (scene sizes)")
    parser.add_argument("--checkpoint-dir", type=Path, required=True, help="of train_ynet_horizon")
    parser.add_argument("--scoring", type=Path, required=True, help="this slot's file of ynet_slot_scoring")
    parser.add_argument("--train-metrics", type=Path, required=True, help="of train_ynet_horizon")
    parser.add_argument("--metrics", type=Path, required=True)
    parser.add_argument("--predictions", type=Path, required=True,
                        help="every round's test predictions (parquet; empty if not trained)")
    args = parser.parse_args(argv)
    trained = json.loads(args.train_metrics.read_text())
    scoring = read_slot_scoring(args.scoring, horizon_slot(args.horizon))
    check_agrees(scoring, trained["trained"], args.scoring, args.train_metrics)
    if scoring is None:
        write_no_predictions(args.predictions, SDD_LONG_TERM.prediction_metadata(YNET, args.table),
                             trained["not_run_reason"])
        write_json(trained, args.metrics)
        print(f"evaluate_ynet_horizon: t_f = {args.horizon} s was not trained: "
              f"{trained['not_run_reason']}")
        return
    score(args, trained, scoring)


def score(args: argparse.Namespace, trained: dict, scoring: SlotScoring) -> None:
    """Score the trained horizon. The modules that load torch are imported here: a horizon the
    profile does not train writes its record above in a fraction of a second."""
    from pipeline.data.semantic_maps import load_semantic_maps
    from pipeline.device import SCORING, describe, select_device
    from pipeline.runners.ynet_scoring import (evaluate, load_for_scoring, prediction_metadata,
                                               sampling_options)
    from pipeline.data.labels import image_sizes

    params = read_params()
    eval_params, rounds = scoring.eval, scoring.eval.rounds
    n_past = load_section(WindowParams, "windows", params).n_past
    device = select_device(load_section(RuntimeParams, "runtime", params).device, purpose=SCORING)

    test = horizon_splits(args.table, n_past, args.horizon)["test"]
    print(f"evaluate_ynet_horizon: scoring on {describe(device)}")
    semantic_maps = load_semantic_maps(args.semantic_maps)
    checkpoint = args.checkpoint_dir / "best.pt"
    model, settings, scenes = load_for_scoring(checkpoint, test, semantic_maps,
                                               image_sizes(args.sdd, set(test.scene_id)),
                                               eval_params.threads, device)
    options = sampling_options(eval_params.k_e, 1, scoring.ttst, scoring.cws, True, True)
    start = time.perf_counter()
    kept = PredictionRounds(test.window_id)
    scores = evaluate(model, scenes, settings, options, eval_params, test.future, rounds,
                      f"t_f={args.horizon}", kept)
    seconds = time.perf_counter() - start
    kept.write(args.predictions, prediction_metadata(args.table, options, checkpoint))
    write_json({"t_f": args.horizon, "profile": scoring.profile, "trained": True, "n_windows": len(test),
                "rounds": rounds, "waypoints": settings.waypoints, "main": scores,
                "eval_seconds": seconds, **training_summary(trained)},
               args.metrics)
    print(f"evaluate_ynet_horizon t_f = {args.horizon}: ADE {scores['ade']['mean']:.2f}  "
          f"FDE {scores['fde']['mean']:.2f} over {len(test)} test windows")


if __name__ == "__main__":
    main()
