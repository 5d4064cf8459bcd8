"""The low-pass and the notch on the master's joint positions, against SciPy's filters of the same design."""

import numpy as np
import pytest
from pydrake.systems.framework import DiagramBuilder
from scipy.signal import butter, iirnotch, lfilter, lfilter_zi

from heft.systems.controller.master_position_filter import MasterPositionFilter
from heft.systems.tick_program import TickProgram

PERIOD, CUTOFF = 0.0005, 60.0
COUNT = 1.5e-4  # rad, one encoder count of the Phantom


def run(positions, cutoff=CUTOFF, notch=0.0, notch_quality=0.7, holds=None):
    """The block's output after each tick of ``positions`` (one row a tick), started on the first; ``holds``:
    each tick's time since the last (s; default the period)."""
    builder = DiagramBuilder()
    block = builder.AddSystem(MasterPositionFilter(cutoff, PERIOD, notch, notch_quality))
    builder.ExportInput(block.GetInputPort("position"), "position")
    builder.ExportInput(block.GetInputPort("hold"), "hold")
    builder.ExportOutput(block.get_output_port(), "position")
    program = TickProgram(builder.Build())
    program.input("position")[:] = positions[0]
    program.reset()
    program.initialize()
    out = []
    for k, row in enumerate(positions):
        program.input("position")[:] = row
        program.input("hold")[:] = PERIOD if holds is None else holds[k]
        program.tick()
        out.append(program.output("position").copy())
    return np.array(out)


def test_counts_are_smoothed_as_scipy_filters_them():
    t = np.arange(400) * PERIOD
    positions = COUNT * np.round(0.01 * np.outer(np.sin(2 * np.pi * 3 * t), np.arange(1, 7)) / COUNT)
    b, a = butter(2, CUTOFF, fs=1 / PERIOD)
    expected = np.column_stack([lfilter(b, a, column, zi=lfilter_zi(b, a) * column[0])[0]
                                for column in positions.T])
    out = run(positions)
    np.testing.assert_allclose(out, expected, rtol=0, atol=1e-12)
    steps = np.abs(np.diff(out, 2, axis=0)).max()  # the counts' jumps are gone from the second difference
    assert steps < 0.5 * np.abs(np.diff(positions, 2, axis=0)).max()


def test_a_non_finite_sample_restarts_the_filter_at_the_next_position():
    positions = np.zeros((20, 6))
    positions[10] = np.nan
    positions[11:] = 0.3
    out = run(positions)
    assert np.isnan(out[10]).all()
    np.testing.assert_allclose(out[11:], 0.3, rtol=1e-15)  # steady at once: no step response from zero


@pytest.mark.parametrize("cutoff", [0.0, -5.0, 1000.0, float("nan")])
def test_a_cutoff_outside_the_band_is_refused_naming_the_setting(cutoff):
    with pytest.raises(ValueError, match="controller.motion.master_filter"):
        MasterPositionFilter(cutoff, PERIOD)


def _scipy(b, a, positions):
    return np.column_stack([lfilter(b, a, column, zi=lfilter_zi(b, a) * column[0])[0] for column in positions.T])


@pytest.mark.parametrize("cutoff", [0.0, CUTOFF])
def test_the_notch_after_the_low_pass_filters_as_scipy_does(cutoff):
    """The notch alone (``controller.motion.master_notch``) and after the low-pass, each stage
    started in its steady state, as SciPy's ``iirnotch`` and ``butter`` in series."""
    t = np.arange(400) * PERIOD
    positions = COUNT * np.round(0.01 * np.outer(np.sin(2 * np.pi * 3 * t), np.arange(1, 7)) / COUNT)
    expected = positions
    if cutoff:
        expected = _scipy(*butter(2, cutoff, fs=1 / PERIOD), expected)
    expected = _scipy(*iirnotch(110.0, 0.7, fs=1 / PERIOD), expected)
    np.testing.assert_allclose(run(positions, cutoff, 110.0), expected, rtol=0, atol=1e-12)


def test_the_notch_takes_the_counts_out_at_the_mounts_modes_and_leaves_the_motion():
    """A 110 Hz ripple of one count is gone (below 2 % of itself after the start); a 3 Hz motion keeps its
    amplitude within 0.5 %, delayed by the notch's group delay at low frequencies, 1/(Q·2π·110 Hz) = 2.1 ms."""
    t = np.arange(2000) * PERIOD
    ripple = run(np.outer(COUNT * np.sin(2 * np.pi * 110 * t), np.ones(6)), 0.0, 110.0)
    assert np.abs(ripple[1000:]).max() < 0.02 * COUNT
    motion = 0.01 * np.sin(2 * np.pi * 3 * t)
    out = run(np.outer(motion, np.ones(6)), 0.0, 110.0)
    assert np.abs(out[1000:, 0]).max() == pytest.approx(0.01, rel=5e-3)
    delayed = 0.01 * np.sin(2 * np.pi * 3 * (t - 1 / (0.7 * 2 * np.pi * 110)))
    assert np.abs(out[1000:, 0] - delayed[1000:]).max() < 0.01 * 0.01


def test_no_filter_at_all_is_refused():
    with pytest.raises(ValueError, match="master_filter and master_notch are both 0"):
        MasterPositionFilter(0.0, PERIOD, 0.0)


@pytest.mark.parametrize("cutoff", [0.0, CUTOFF])
def test_a_tick_late_by_one_period_catches_the_filter_up(cutoff):
    """A tick skipped in a steady motion (the next one 2 periods after the last): the stages step twice, the
    first time on the position halfway, and the output goes on as if no tick had been skipped; stepped once,
    the notch's output would dip by up to 65 % of the skipped tick's motion."""
    velocity = 0.2 * np.arange(1, 7)  # rad/s
    t = np.arange(400) * PERIOD
    positions = np.outer(t, velocity)
    every = run(positions, cutoff, 110.0)
    ticks = np.delete(np.arange(400), 200)  # tick 200 skipped
    holds = np.full(len(ticks), PERIOD)
    holds[200] = 2 * PERIOD
    late = run(positions[ticks], cutoff, 110.0, holds=holds)
    np.testing.assert_allclose(late, every[ticks], rtol=0, atol=1e-12)
    once = run(positions[ticks], cutoff, 110.0)
    dip = np.abs(once - every[ticks]).max(axis=0) / (velocity * PERIOD)
    assert dip.min() > 0.3


def test_the_loops_jitter_steps_the_filter_once_a_tick():
    """Ticks 1.7 and then 0.3 periods apart, within what the loop tolerates without skipping one
    (``CATCH_UP_FROM``), step the stages once each, as ticks on time do."""
    positions = np.outer(np.arange(400) * PERIOD, 0.2 * np.arange(1, 7))
    holds = np.full(400, PERIOD)
    holds[100::50], holds[101::50] = 1.7 * PERIOD, 0.3 * PERIOD
    np.testing.assert_array_equal(run(positions, CUTOFF, 110.0, holds=holds), run(positions, CUTOFF, 110.0))
