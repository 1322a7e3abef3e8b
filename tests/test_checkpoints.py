"""The shared resumable-checkpoint scheme (`pipeline.checkpoints`): resuming, the run digest and the
seeding. The loops' own resume-exactly tests live beside each loop (test_train_ynet,
test_segmentation_device, test_baselines_device)."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch

from pipeline import checkpoints

IDENTITY = {"lr": 0.001, "data_fingerprint": "abc"}


def saved(epoch: int = 2, position: dict | None = None, identity: dict = IDENTITY) -> dict:
    return {"format": checkpoints.FORMAT, "identity": identity, "epoch": epoch, "position": position,
            "state": {}}


def test_a_checkpoint_of_the_same_run_within_its_budget_resumes():
    assert checkpoints.stale_reason(saved(2), IDENTITY, epochs=2) is None
    assert checkpoints.stale_reason(saved(2), IDENTITY, epochs=5) is None  # the budget may grow
    assert checkpoints.stale_reason(saved(1, {"step": 3}), IDENTITY, epochs=2) is None


@pytest.mark.parametrize("checkpoint, why", [
    ({"format": 2, "epoch": 1}, "checkpoint format 2"),
    (saved(identity={"lr": 0.01, "data_fingerprint": "abc"}), "other lr"),
    (saved(identity={"lr": 0.001, "data_fingerprint": "abd", "seed": 1}), "other data_fingerprint, seed"),
    (saved(3), "begun 3 epochs, more than the 2"),
    (saved(2, {"step": 0}), "begun 3 epochs"),  # a mid-epoch position counts its epoch as begun
])
def test_stale_checkpoints_say_why(checkpoint, why):
    assert why in checkpoints.stale_reason(checkpoint, IDENTITY, epochs=2)


def test_save_then_resume_round_trip(tmp_path, capsys):
    path = tmp_path / "run" / checkpoints.LAST
    path.parent.mkdir()
    assert checkpoints.resume(path, IDENTITY, 3, "test") is None  # nothing there: silent
    weights = {"w": torch.arange(6.0).reshape(2, 3)}
    checkpoints.save(path, IDENTITY, 2, {"model": weights, "history": [{"epoch": 1}]}, {"step": 4})
    resumed = checkpoints.resume(path, IDENTITY, 3, "test")
    assert resumed.epoch == 2 and resumed.position == {"step": 4}
    torch.testing.assert_close(resumed.state["model"]["w"], weights["w"], rtol=0, atol=0)
    assert checkpoints.read(path).state["history"] == [{"epoch": 1}]
    assert capsys.readouterr().out == ""
    assert checkpoints.resume(path, {**IDENTITY, "lr": 0.1}, 3, "test") is None
    out = capsys.readouterr().out
    assert str(path) in out and "other lr" in out and "starting afresh" in out
    assert list(path.parent.iterdir()) == [path]  # written atomically: no temporary left over


def test_read_refuses_another_layout(tmp_path):
    torch.save({"format": 2}, tmp_path / "last.pt")
    with pytest.raises(ValueError, match="last.pt"):
        checkpoints.read(tmp_path / "last.pt")


def windows(offset: int):
    """Three fixed windows (ids, scenes, frames, positions); only what `run_digest` reads."""
    from pipeline.data.window_table import WindowArrays
    n = 3
    return WindowArrays(past=(np.arange(n * 8, dtype=float).reshape(n, 4, 2) + offset) * 1.5,
                        future=(np.arange(n * 4, dtype=float).reshape(n, 2, 2) - offset) * 0.25,
                        window_id=np.arange(n) + 10 * offset,
                        scene_id=np.array(["gates_2", "coupa_3", "gates_2"], dtype=object),
                        track_id=np.arange(n), first_frame=np.arange(n) * 30 + offset,
                        split=np.array(["train"] * n))


MAPS = {"gates_2": np.arange(24, dtype=np.float32).reshape(2, 3, 4),
        "coupa_3": np.ones((2, 3, 4), np.float32)}
# What Y-net's run fingerprint hashed ahead of the windows for a cpu-like run, before run_digest
YNET_HEAD = json.dumps({"n_past": 8, "settings": {
    "augmentations": 8, "batch_size": 2, "bf16": True, "decoder_channels": [64, 64, 64, 32, 32],
    "distance_gain": 8.0, "distance_norm": "upstream", "encoder_channels": [32, 32, 64, 64, 64],
    "head_bias": -15.0, "kernel_size": 31, "learning_rate": 0.0001, "loss_scale": 1000.0,
    "lr_schedule": "cosine", "resize": 0.0625, "seed": 0, "sigma": 4.0, "waypoints": [14, 29]}},
    sort_keys=True)


def test_run_digest_gives_the_values_of_the_hashes_it_replaced():
    """Pinned to what two of the copies it replaced returned on these inputs (computed with them
    before they went): the baselines' `common.fingerprint(7, a, b)` and Y-net's `run_fingerprint`,
    whose settings part is `YNET_HEAD`. inD's run stamp, the third, hashed its maps without their
    names and is gone with its resume scheme (Y-net's identity covers inD's runs)."""
    a, b = windows(0), windows(1)
    assert (checkpoints.run_digest("7", a, b)
            == "f7314d8686d676eed225523aa28005fad9d997aaa7a603c7adbec1cd103671a9")
    assert (checkpoints.run_digest(YNET_HEAD, a, b, maps=MAPS)
            == "cab6e219478cdf4cd6e27d52cbcaf061c65b15ef5f4f111d4d4560563652087d")
    same = checkpoints.run_digest(YNET_HEAD, a, b, maps=MAPS)
    assert checkpoints.run_digest(YNET_HEAD, a, windows(2), maps=MAPS) != same
    assert checkpoints.run_digest(YNET_HEAD, a, b, maps={**MAPS, "coupa_3": 0 * MAPS["coupa_3"]}) != same
    assert checkpoints.run_digest("8", a, b) != checkpoints.run_digest("7", a, b)


def test_seed_everything_seeds_the_global_rngs_and_returns_a_seeded_generator():
    import random
    generator = checkpoints.seed_everything(5)
    drawn = (random.random(), np.random.rand(), torch.rand(1).item(),
             torch.rand(1, generator=generator).item())
    generator = checkpoints.seed_everything(5)
    assert drawn == (random.random(), np.random.rand(), torch.rand(1).item(),
                     torch.rand(1, generator=generator).item())
    assert drawn[3] == torch.rand(1, generator=torch.Generator().manual_seed(5)).item()
