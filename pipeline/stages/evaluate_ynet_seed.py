"""Stage `evaluate_ynet_seed@<seed>`: the Y-net of an extra training seed (`train_ynet_seed`) scored
in `evaluate_ynet`'s main setting.

TTST + CWS at `eval.<profile>`'s K_e and K_a over its rounds and round seeds (as
`ynet_slot_scoring` resolved them into `--scoring`, a dep instead of those params: a slot the
profile does not train is not re-run by a sampling change), on the release's
t_f = 30 test windows (`pipeline.runners.ynet_scoring.evaluation_sequence` without the ablation and
the grid, as `evaluate_ynet --main-only`), so that only training differs between this record and
`metrics/ynet_eval.json`. Writes {profile, t_f, n_windows, rounds,
training_seed (from the checkpoint), trained, main (the layout of ynet_eval.json's main: summary,
k_e, k_a, per_round), main_seconds, eval_seconds, <training summary>}; no ablation, K_a grid or
stored predictions. A seed that was not trained gets the training stage's not-run record. Params:
`runtime.device` (and `windows.n_past`, passed as --n-past).

    python -m pipeline.stages.evaluate_ynet_seed --windows data/windows/release_tf30.parquet \
        --semantic-maps data/semantic_maps --sdd data/raw/sdd --n-past 5 \
        --checkpoint-dir checkpoints/ynet_seeds/seed1 --scoring data/ynet_slot_scoring/seed1.json \
        --train-metrics metrics/ynet_seeds/train_seed1.json --metrics metrics/ynet_seeds/seed1.json
"""

from __future__ import annotations

import argparse
from pathlib import Path

import pandas as pd

from pipeline.config.loading import load_section, read_params
from pipeline.config.runtime import RuntimeParams
from pipeline.data.window_table import to_arrays
from pipeline.io import exit_on_bad_intermediate, index_value, read_json_index, write_json
from pipeline.runners.slot_scoring import SlotScoring, check_agrees, read_slot_scoring, seed_slot


@exit_on_bad_intermediate
def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--windows", type=Path, required=True)
    parser.add_argument("--semantic-maps", type=Path, required=True)
    parser.add_argument("--sdd", type=Path, required=True)
    parser.add_argument("--n-past", type=int, default=5)
    parser.add_argument("--checkpoint-dir", type=Path, required=True, help="of train_ynet_seed")
    parser.add_argument("--scoring", type=Path, required=True, help="this slot's file of ynet_slot_scoring")
    parser.add_argument("--train-metrics", type=Path, required=True, help="of train_ynet_seed")
    parser.add_argument("--metrics", type=Path, required=True)
    args = parser.parse_args(argv)
    trained = read_json_index(args.train_metrics)
    slot = seed_slot(index_value(trained, "seed", int, args.train_metrics))
    scoring = read_slot_scoring(args.scoring, slot)
    check_agrees(scoring, index_value(trained, "trained", bool, args.train_metrics), args.scoring,
                 args.train_metrics)
    if scoring is None:
        write_json(trained, args.metrics)
        print(f"evaluate_ynet_seed: not trained: {trained.get('not_run_reason')}")
        return
    score(args, trained, scoring)


def score(args: argparse.Namespace, trained: dict, scoring: SlotScoring) -> None:
    """Score the trained seed. The modules that load torch are imported here: a slot the profile
    does not train writes its record above in a fraction of a second."""
    from pipeline.data.semantic_maps import load_semantic_maps
    from pipeline.device import SCORING, describe, select_device
    from pipeline.runners.ynet_main import TRAINING_KEYS
    from pipeline.runners.ynet_scoring import evaluation_sequence, load_for_scoring
    from pipeline.data.labels import image_sizes

    training = {key: index_value(trained, key, kind, args.train_metrics) for key, kind in TRAINING_KEYS}
    eval_params = scoring.eval
    runtime = load_section(RuntimeParams, "runtime", read_params())
    device = select_device(runtime.device, purpose=SCORING)

    print(f"evaluate_ynet_seed: on {describe(device)}")
    table = pd.read_parquet(args.windows)
    test = to_arrays(table[table["split"] == "test"], args.n_past)
    semantic_maps = load_semantic_maps(args.semantic_maps)
    model, settings, scenes = load_for_scoring(args.checkpoint_dir / "best.pt", test, semantic_maps,
                                               image_sizes(args.sdd, set(test.scene_id)),
                                               eval_params.threads, device)
    scores = evaluation_sequence(model, scenes, settings, eval_params, scoring.ttst, scoring.cws,
                                 test.future, extras=False)
    write_json({"profile": scoring.profile, "t_f": int(test.future.shape[1]),
                "n_windows": len(test), "rounds": eval_params.rounds, "trained": True,
                "training_seed": settings.seed, **scores, **training}, args.metrics)
    print(f"evaluate_ynet_seed: training seed {settings.seed}: "
          f"ADE {scores['main']['ade']['mean']:.2f} ± {scores['main']['ade']['std']:.2f}  "
          f"FDE {scores['main']['fde']['mean']:.2f} ± {scores['main']['fde']['std']:.2f} "
          f"(over {eval_params.rounds} evaluation rounds)")


if __name__ == "__main__":
    main()
