"""The two-link arm with friction and a wall (paper Figs. 2–3)."""

import numpy as np
import pytest

from ltvmodels.apps.robot import (
    hand_position,
    plot_robot_experiment,
    robot_experiment,
    two_link_robot,
)


@pytest.fixture(scope="module")
def experiment():
    return robot_experiment(seed=0, validation_seed=1)


def test_simulation_respects_the_wall_and_has_the_paper_events():
    run = two_link_robot(seed=0)
    assert run.x.shape == (201, 4) and run.u.shape == (201, 3)
    np.testing.assert_array_equal(run.u[:, 2], 1.0)
    heights = run.end_effector[:, 1]
    assert heights.max() <= run.wall_height + 1e-9  # never through the wall
    np.testing.assert_allclose(heights[run.in_contact], run.wall_height, atol=1e-9)
    # On the wall the end effector moves along it only: zero normal velocity.
    on_wall = np.flatnonzero(run.in_contact)
    assert on_wall.size and np.all(np.diff(on_wall) == 1)  # stays in contact once made
    np.testing.assert_allclose(
        [hand_position(q)[1] for q in run.x[on_wall, :2]], run.wall_height, atol=1e-9
    )
    assert 50 <= run.sign_change_index <= 100  # paper: sign change in 50–100
    assert 100 <= run.contact_index <= 150  # paper: contact in 100–150
    # The controller's friction compensation makes the torque jump there.
    jumps = np.abs(np.diff(run.u[:, 1]))
    window = slice(run.sign_change_index - 3, run.sign_change_index + 2)
    assert jumps[window].max() > 5 * np.median(jumps[: run.contact_index])


def test_same_seed_same_run_other_seed_other_contact_time():
    a, b, c = two_link_robot(seed=3), two_link_robot(seed=3), two_link_robot(seed=4)
    np.testing.assert_array_equal(a.x, b.x)
    assert a.contact_index != c.contact_index


def test_activation_peaks_at_the_friction_change_and_the_contact(experiment):
    train = experiment.train
    found = experiment.changepoints
    for event in (train.sign_change_index, train.contact_index):
        assert np.min(np.abs(found - event)) <= 5
    a = experiment.model.activation()
    contact_peak = a[train.contact_index - 6 : train.contact_index + 5].max()
    assert contact_peak == a.max()


def test_the_model_is_time_locked_at_the_contact(experiment):
    """Good open-loop fit on the training run, a transient error on validation data."""
    assert experiment.validation.contact_index != experiment.train.contact_index
    assert experiment.rms_train < 0.1
    assert experiment.rms_validation > 3 * experiment.rms_train
    before = min(experiment.train.contact_index, experiment.validation.contact_index) - 30
    err = np.abs(experiment.simulation_validation - experiment.x_validation)
    assert err[:before].mean() < err[before:].mean()


def test_plots(experiment):
    import matplotlib

    matplotlib.use("Agg")
    for which in ("train", "validation"):
        fig = plot_robot_experiment(experiment, which)
        assert len(fig.axes) == 5
    with pytest.raises(ValueError, match="^which:"):
        plot_robot_experiment(experiment, "test")
