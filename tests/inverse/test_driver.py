"""The one Adam loop of inverse rendering (mitsuba_pbrdf.inverse.driver) and
the fits that use it (fit_parameters, recover_normals, svbrdf.recover).

Oracles: the seeding policy (mitsuba_pbrdf.rendering.passes.pass_seeds,
exact integers: the renders of a fit, numbered in order, get that sequence's
seeds); the learning-rate schedule's closed form (first rate lr, last
lr * lr_end, to 1e-12 relative); a loss whose minimum lies outside the
bounds (the clamp must hold every iterate on the bound, exactly); and Ctrl-C
as a real SIGINT under Python's own handler (KeyboardInterrupt out of the
loop, no callback for the interrupted iteration). The fits run at toy sizes
(8 x 8 pixels, 1-2 spp, 2 iterations): only the seeds they render with are
checked here; what they recover is tested in test_inverse.py,
tests/inverse/test_normals.py and tests/integrators/test_stokes_prb.py.
"""

import os
import signal

import drjit as dr
import mitsuba as mi
import numpy as np
import pytest

from mitsuba_pbrdf.inverse.driver import LR_END, iteration_seeds, learning_rates, run_adam
from mitsuba_pbrdf.rendering.passes import pass_seeds


def _quadratic(target, record=None):
    """gradient(opt, it, seeds) of (x - target)^2, recording (it, seeds, x, lr)."""

    def gradient(opt, it, seeds):
        x = opt["x"]
        if record is not None:
            record.append((it, list(seeds), float(x[0]), opt.lr))
        loss = dr.square(x - target)
        dr.backward(loss)
        return float(loss[0])

    return gradient


def test_each_iteration_renders_with_the_next_block_of_the_pass_seeds():
    record = []
    run_adam({"x": mi.Float(0.0)}, _quadratic(1.0, record), [0.1] * 5, seed=77, renders=3)
    seeds = [s for _, block, _, _ in record for s in block]
    assert seeds == pass_seeds(77, 15)           # renders numbered in order, one sequence
    assert len(set(seeds)) == 15
    assert [block for _, block, _, _ in record] == [iteration_seeds(77, it, 3) for it in range(5)]
    assert iteration_seeds(77, 0, 1) == [77]     # the first render: exactly mi.render(seed=seed)
    assert iteration_seeds(2 ** 32 - 1, 1, 1) == pass_seeds(2 ** 32 - 1, 2)[1:]  # 32-bit


def test_the_schedule_runs_from_lr_to_lr_end_and_the_optimizer_follows_it():
    for n in (1, 2, 40):
        rates = learning_rates(0.05, n)
        assert rates[0] == 0.05
        if n > 1:
            np.testing.assert_allclose(rates[-1], 0.05 * LR_END, rtol=1e-12)
    np.testing.assert_allclose(learning_rates(0.05, 4, lr_end=0.5)[[0, -1]], [0.05, 0.025],
                               rtol=1e-12)
    assert list(learning_rates(0.2, 3, lr_decay=1.0)) == [0.2, 0.2, 0.2]  # constant
    rates = learning_rates(0.05, 6, lr_end=0.2)
    record = []
    run_adam({"x": mi.Float(0.0)}, _quadratic(1.0, record), rates)
    assert [lr for *_, lr in record] == [float(r) for r in rates]  # each step at its own rate


def test_the_clamp_runs_after_every_step_and_holds_the_iterates_in_bounds():
    """The loss pulls x to 5; the clamp keeps it in [0, 1]: every iterate after
    the first is exactly on the bound, and the clamp ran once per step."""
    record, clamps = [], []

    def clamp(opt):
        clamps.append(float(opt["x"][0]))
        opt["x"] = dr.clip(opt["x"], 0.0, 1.0)

    calls = []
    run = run_adam({"x": mi.Float(0.5)}, _quadratic(5.0, record), [0.8] * 6, clamp=clamp,
                   callback=lambda it, loss: calls.append((it, loss)))
    assert len(clamps) == 6 and max(clamps) > 1.0      # a step left the bounds; clamped back
    assert [x for _, _, x, _ in record] == [0.5] + [1.0] * 5
    assert float(run.optimizer["x"][0]) == 1.0
    assert calls == [(it, loss) for it, loss in enumerate(run.loss)] and len(run.loss) == 6
    assert run.loss == [20.25] + [16.0] * 5            # (0.5 - 5)^2, then (1 - 5)^2


def test_ctrl_c_leaves_the_loop_at_once(python_sigint_handler):
    """A real SIGINT during iteration 2 (Python's handler): KeyboardInterrupt
    out of run_adam, the callback seen for iterations 0 and 1 only."""
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    seen, calls = [], []

    def gradient(opt, it, seeds):
        seen.append(it)
        if it == 2:
            os.kill(os.getpid(), signal.SIGINT)
        return _quadratic(1.0)(opt, it, seeds)

    with pytest.raises(KeyboardInterrupt):
        run_adam({"x": mi.Float(0.0)}, gradient, [0.1] * 5,
                 callback=lambda it, loss: calls.append(it))
    assert seen == [0, 1, 2] and calls == [0, 1]


def test_fit_parameters_seeds_each_iterations_passes_from_the_policy(monkeypatch):
    """With 2 passes an iteration renders with 2 seeds: iteration it gets
    renders 2 it and 2 it + 1 of pass_seeds (loss_and_gradient seeds its
    passes from the first)."""
    from mitsuba_pbrdf.inverse import optimize, render, sphere_scene

    scene = mi.load_dict(sphere_scene(8, 8, 2, 3, integrator="direct"))
    target = np.array(render(scene, spp=4, seed=1))
    seen, original = [], optimize.loss_and_gradient

    def recording(*args, **kwargs):
        seen.append(kwargs["seed"])
        return original(*args, **kwargs)

    monkeypatch.setattr(optimize, "loss_and_gradient", recording)
    result = optimize.fit_parameters(scene, ["object.bsdf.sigma.value"], target, iterations=3,
                                     spp=2, seed=9, method="reverse", passes=2)
    assert seen == [iteration_seeds(9, it, 2)[0] for it in range(3)] == pass_seeds(9, 6)[::2]
    assert len(result.loss) == len(result.trajectory) == 3


def test_recover_normals_renders_each_view_with_its_seed_from_the_policy(monkeypatch):
    from mitsuba_pbrdf.inverse.normals import scenes as ns
    from mitsuba_pbrdf.inverse import recover_normals

    truth = ns.true_normals(4)
    scene = mi.load_dict(ns.plate_scene(truth, views=3, size=8, spp=1))
    targets = ns.render_targets(scene, spp=2)
    seen, render = [], mi.render

    def recording(*args, **kwargs):
        seen.append((kwargs["sensor"], kwargs["seed"]))
        return render(*args, **kwargs)

    monkeypatch.setattr(mi, "render", recording)
    recover_normals(scene, targets, iterations=2, spp=1, seed=5)
    assert seen == [(view, pass_seeds(5, 6)[3 * it + view]) for it in range(2) for view in range(3)]


def test_svbrdf_recover_renders_each_view_with_its_seed_from_the_policy(monkeypatch):
    from mitsuba_pbrdf.inverse import svbrdf

    seen, render = [], mi.render

    def recording(*args, **kwargs):
        if "params" in kwargs or len(args) > 1:  # the fit's renders, not the targets'
            seen.append((kwargs["sensor"], kwargs["seed"]))
        return render(*args, **kwargs)

    monkeypatch.setattr(mi, "render", recording)
    svbrdf.recover(iterations=2, size=8, spp=1, target_spp=2, seed=3, log=None)
    assert seen == [(view, pass_seeds(3, 6)[3 * it + view]) for it in range(2) for view in range(3)]
