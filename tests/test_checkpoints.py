"""The shared resumable-checkpoint scheme (`pipeline.checkpoints`) and the upgrade of older layouts
(`tools/upgrade_checkpoints.py`). The loops' own resume-exactly tests live beside each loop
(test_train_ynet, test_segmentation_device, test_baselines_device)."""

from __future__ import annotations

import pytest
import torch

from pipeline import checkpoints
from tools import upgrade_checkpoints

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


def ynet_legacy(losses: list[float] | None) -> dict:
    """A `last.pt` as `pipeline.runners.ynet_training.train` wrote it before the shared scheme
    (`losses` None: before mid-epoch checkpoints, without `partial_losses`)."""
    saved = {"model": {"w": torch.ones(2)}, "optimizer": {"state": {}, "param_groups": []},
            "rng": {"numpy_plan": {"state": 7}, "torch": torch.zeros(3, dtype=torch.uint8)},
            "state": {"epoch": 4, "history": [{"epoch": e} for e in range(1, 5)],
                      "best": {"epoch": 3, "val_ade": 9.5}, "seconds": 12.5},
            "run_id": "f00d", "partial_losses": losses}
    return saved if losses is not None else {k: v for k, v in saved.items() if k != "partial_losses"}


@pytest.mark.parametrize("losses, position", [(None, None), ([], None),
                                              ([0.5, 0.25], {"losses": [0.5, 0.25]})])
def test_a_ynet_checkpoint_of_the_older_layout_is_upgraded(tmp_path, losses, position):
    path = tmp_path / "last.pt"
    torch.save(ynet_legacy(losses), path)
    assert upgrade_checkpoints.upgrade(path, check=True)
    assert checkpoints.load(path)["run_id"] == "f00d"  # --check rewrites nothing
    assert upgrade_checkpoints.upgrade(path)
    resumed = checkpoints.resume(path, {"run": "f00d"}, 5, "test")
    assert resumed.epoch == 4 and resumed.position == position
    assert resumed.state["progress"] == {"history": [{"epoch": e} for e in range(1, 5)],
                                         "best": {"epoch": 3, "val_ade": 9.5}, "seconds": 12.5}
    assert resumed.state["rng"]["numpy_plan"] == {"state": 7}
    assert not upgrade_checkpoints.upgrade(path)


def test_an_unknown_file_is_an_error_naming_it(tmp_path):
    torch.save({"weights": torch.ones(1)}, tmp_path / "last.pt")
    with pytest.raises(ValueError, match="last.pt.*weights"):
        upgrade_checkpoints.upgrade(tmp_path / "last.pt")
