import numpy as np

from pipeline.data.audit import compare_video, explain

A = ("gates_2", 1, (0, 30, 60))
B = ("gates_2", 2, (0, 30, 60))
C = ("gates_2", 1, (1, 31, 61))
XY = np.arange(6.0).reshape(3, 2)


def test_compare_video_classifies_windows():
    ours = {A: XY, B: XY + 1}
    release = {A: XY, B: XY, C: XY}
    result = compare_video(ours, release)
    assert (result.ours, result.release, result.exact_matches) == (2, 3, 1)
    assert result.only_release == [C] and result.position_differs == [B] and result.only_ours == []


def test_explain_by_the_other_compat_setting():
    release = {C: XY}
    other = {C: XY}  # the other drop_first_row setting reproduces the release window
    assert "compat.drop_first_row=true" in explain(C, release, other, True)
    assert "compat.drop_first_row=false" in explain(A, release, other, False)  # ours only, other agrees
    assert explain(C, release, {}, True) is None  # nothing accounts for it
    assert explain(C, release, {C: XY + 1}, True) is None
