"""The benchmarks' fixed splits: TrajNet's SDD train/test videos, as the paper uses for the
long-term benchmark, and the ETH/UCY leave-one-scene-out folds.

Test scenes are never seen in training. The validation split (for model selection) is carved from
the train videos by `params.yaml` `split.val_videos`; the authors selected on the test set
(upstream bug 2), which this project does not do.

The module imports nothing, so that `pipeline.config` can check params against these facts.
"""

from __future__ import annotations

# TrajNet test videos (17): the paper evaluates on these, unseen in training.
TEST_VIDEOS = frozenset({
    "coupa_0", "coupa_1", "gates_2", "hyang_0", "hyang_1", "hyang_3", "hyang_8",
    "little_0", "little_1", "little_2", "little_3", "nexus_5", "nexus_6",
    "quad_0", "quad_1", "quad_2", "quad_3",
})
# TrajNet train videos (30).
TRAIN_VIDEOS = frozenset({
    "bookstore_0", "bookstore_1", "bookstore_2", "bookstore_3", "coupa_3",
    "deathCircle_0", "deathCircle_1", "deathCircle_2", "deathCircle_3", "deathCircle_4",
    "gates_0", "gates_1", "gates_3", "gates_4", "gates_5", "gates_6", "gates_7", "gates_8",
    "hyang_4", "hyang_5", "hyang_6", "hyang_7", "hyang_9",
    "nexus_0", "nexus_1", "nexus_3", "nexus_4", "nexus_7", "nexus_8", "nexus_9",
})
# The other 13 of SDD's 60 videos (e.g. bookstore 4-6, hyang 12-14, nexus 10) are in neither.


def split_of(scene_id: str, val_videos: frozenset[str] | set[str]) -> str | None:
    """'train' / 'val' / 'test' for a `<scene>_<video>` id, None when outside the split."""
    if scene_id in TEST_VIDEOS:
        return "test"
    if scene_id in val_videos:
        return "val"
    if scene_id in TRAIN_VIDEOS:
        return "train"
    return None


SDD_RAW_FPS = 30  # SDD annotation frames per second; TrajNet frame numbers are raw frame numbers

# ETH/UCY leave-one-scene-out folds (SGAN's folders, the short-term benchmark): fold -> the
# scene(s) it tests on; the other scenes train and validate it.
FOLD_TEST_SCENES = {
    "eth": {"eth"},
    "hotel": {"hotel"},
    "univ": {"students001", "students003"},
    "zara1": {"zara1"},
    "zara2": {"zara2"},
}
