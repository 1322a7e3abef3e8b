"""The TTST grid of `docs/experiments/short_term_ttst.py`: the profile's setting first, none twice."""

from docs.experiments.short_term_ttst import ttst_grid


def test_ttst_grid_puts_the_profile_first_and_drops_repeats():
    grid = ttst_grid([0.5, 1.0], [0.01, 0.05], (1.0, 0.01))
    assert grid[0] == (1.0, 0.01)
    assert len(grid) == len(set(grid)) == 4
    assert set(grid) == {(0.5, 0.01), (0.5, 0.05), (1.0, 0.01), (1.0, 0.05)}


def test_ttst_grid_keeps_a_profile_setting_outside_the_grid():
    grid = ttst_grid([2.0], [0.01], (1.0, 0.01))
    assert grid == [(1.0, 0.01), (2.0, 0.01)]
