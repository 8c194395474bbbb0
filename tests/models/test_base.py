"""The shared Params/Model machinery, exercised through SkidSteer (the simplest model)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from wheelgym.models import SkidSteer, SkidSteerParams

X0 = np.array([0.1, -0.2, 0.3, 0.5, 0.2])
U0 = np.array([1.0, 2.0, -3.0, 4.0])


class _NoFastPath(SkidSteer):
    """SkidSteer without the single-state kernels: exercises the generic 1-D path."""

    _k_step1 = None
    _k_deriv1 = None


@pytest.fixture(scope="module", params=[SkidSteer, _NoFastPath])
def model(request) -> SkidSteer:
    return request.param()


def test_generic_single_state_path_same_bits():
    fast, generic = SkidSteer(), _NoFastPath()
    assert generic._step1 is None
    rng = np.random.default_rng(4)
    for _ in range(20):
        x, u = rng.normal(0, 1, 5), rng.uniform(-30, 30, 4)
        np.testing.assert_array_equal(generic.step(x, u, 0.05, 40), fast.step(x, u, 0.05, 40))
        np.testing.assert_array_equal(generic.derivative(x, u), fast.derivative(x, u))


# ---------------------------------------------------------------------------- Params
def test_params_defaults_roundtrip():
    p = SkidSteerParams()
    assert SkidSteerParams.from_dict(p.to_dict()) == p
    assert p.replace(m=40.0).m == 40.0 and p.m == 56.6
    assert hash(p) == hash(SkidSteerParams())
    with pytest.raises(dataclasses.FrozenInstanceError):
        p.m = 1.0  # type: ignore[misc]
    assert p.pack().dtype == np.float64 and p.pack().shape == (23,)  # 12 + 1/r, motor (11)


@pytest.mark.parametrize("build", [
    lambda: SkidSteerParams(mass=3.0),
    lambda: SkidSteerParams.from_dict({"mass": 3.0}),
    lambda: SkidSteerParams.from_dict(None, mass=3.0),
    lambda: SkidSteerParams().replace(mass=3.0),
    lambda: SkidSteer(mass=3.0),
    lambda: SkidSteer({"mass": 3.0}),
])
def test_params_unknown_name_raises_type_error(build):
    with pytest.raises(TypeError, match="mass"):
        build()


def test_params_error_lists_valid_names():
    with pytest.raises(TypeError, match="valid names"):
        SkidSteerParams.from_dict({"mu": 0.1})


@pytest.mark.parametrize(("field", "value"), [
    ("m", 0.0), ("m", -1.0), ("I", 0.0), ("r", 0.0), ("r", -0.1), ("a", 0.0), ("b", -0.1),
    ("c", 0.0), ("k_s", 0.0), ("g", 0.0), ("tau_max", 0.0), ("mu_s", -0.01), ("mu_l", -1.0),
    ("m", float("nan")), ("r", float("inf")), ("mu_l", float("nan")),
    ("x_icr", 0.3), ("x_icr", -0.3), ("x_icr", 0.226), ("x_icr", float("nan")),
])
def test_params_nonphysical_raise_value_error_naming_field(field, value):
    with pytest.raises(ValueError, match=field):
        SkidSteerParams(**{field: value})


@pytest.mark.parametrize("value", ["heavy", None, True, [1.0, 2.0, object()]])
def test_params_non_numeric_raise_type_error(value):
    with pytest.raises(TypeError, match="m"):
        SkidSteerParams(m=value)


def test_model_construction():
    p = SkidSteerParams(m=40.0)
    assert SkidSteer(p).params is p
    assert SkidSteer(p, I=2.0).params == p.replace(I=2.0)
    assert SkidSteer({"m": 40.0}, I=2.0).params == p.replace(I=2.0)
    assert SkidSteer(m=40.0).params == p
    with pytest.raises(TypeError, match="params"):
        SkidSteer(3.0)  # type: ignore[arg-type]
    free = SkidSteer().frictionless()
    assert free.params.mu_s == 0.0 and free.params.mu_l == 0.0
    assert "SkidSteer" in repr(SkidSteer())


# ---------------------------------------------------------------------------- shapes
@pytest.mark.parametrize(("xs", "us", "out"), [
    ((5,), (4,), (5,)),
    ((1, 5), (1, 4), (1, 5)),
    ((7, 5), (7, 4), (7, 5)),
    ((2, 3, 5), (2, 3, 4), (2, 3, 5)),
    ((5,), (6, 4), (6, 5)),  # one state, many inputs
    ((6, 5), (4,), (6, 5)),  # one input for all states
    ((2, 1, 5), (1, 3, 4), (2, 3, 5)),
])
def test_shapes_and_broadcasting(model, xs, us, out):
    rng = np.random.default_rng(0)
    x = rng.normal(size=xs)
    u = rng.normal(size=us)
    d = model.derivative(x, u)
    s = model.step(x, u, 0.05, 4)
    assert d.shape == out and s.shape == out
    # each entry equals the single-state answer for its broadcast pair
    xb, ub = np.broadcast_to(x, out), np.broadcast_to(u, out[:-1] + (4,))
    flat = [(xb.reshape(-1, 5)[i], ub.reshape(-1, 4)[i]) for i in range(int(np.prod(out[:-1])))]
    np.testing.assert_array_equal(
        s.reshape(-1, 5), np.stack([model.step(np.array(a), np.array(b), 0.05, 4) for a, b in flat])
    )


def test_fast_path_equals_general_path(model):
    # The 1-D float64 fast path and the generic batch path run the same compiled physics.
    fast = model.step(X0, U0, 0.05, 40)
    as_list = model.step(X0.tolist(), U0.tolist(), 0.05, 40)
    batch = model.step(X0[None], U0[None], 0.05, 40)[0]
    strided = model.step(np.repeat(X0, 2)[::2], U0, 0.05, 40)
    f32 = model.step(X0, U0.astype(np.float32), 0.05, 40)  # u not float64: general path
    ro = X0.copy()
    ro.setflags(write=False)
    readonly = model.step(ro, U0, 0.05, 40)
    for other in (as_list, batch, strided, readonly):
        np.testing.assert_array_equal(fast, other)
    np.testing.assert_allclose(f32, fast, rtol=0, atol=0)  # U0 is exact in float32
    np.testing.assert_array_equal(model.step(X0, U0, 0.05, np.int64(40)), fast)
    np.testing.assert_array_equal(model.derivative(X0, U0), model.derivative([X0], [U0])[0])


def test_step_returns_new_array(model):
    x = X0.copy()
    out = model.step(x, U0, 0.05, 2)
    np.testing.assert_array_equal(x, X0)
    assert out is not x and not np.shares_memory(out, x)
    assert model.step(x, U0, 0.05) is not model.step(x, U0, 0.05)


# ---------------------------------------------------------------------------- bad input
@pytest.mark.parametrize("x", [np.zeros(4), np.zeros(6), np.zeros((3, 6)), np.float64(1.0)])
def test_wrong_state_size(model, x):
    with pytest.raises(ValueError, match="x must have shape"):
        model.step(x, U0, 0.05)
    with pytest.raises(ValueError, match="x must have shape"):
        model.derivative(x, U0)


@pytest.mark.parametrize("u", [np.zeros(3), np.zeros(5), np.zeros((2, 5)), 1.0])
def test_wrong_input_size(model, u):
    with pytest.raises(ValueError, match="u must have shape"):
        model.step(X0, u, 0.05)
    with pytest.raises(ValueError, match="u must have shape"):
        model.derivative(X0, u)


def test_leading_shapes_must_broadcast(model):
    with pytest.raises(ValueError, match="broadcast"):
        model.step(np.zeros((3, 5)), np.zeros((2, 4)), 0.05)


def test_non_numeric_input(model):
    with pytest.raises(TypeError, match="x"):
        model.step(["a"] * 5, U0, 0.05)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
@pytest.mark.parametrize("lead", [(), (3,), (600,)])  # fast path, serial and parallel kernels
def test_non_finite_state_or_input_raises(model, bad, lead):
    x = np.broadcast_to(X0, lead + (5,)).copy()
    u = np.broadcast_to(U0, lead + (4,)).copy()
    x.reshape(-1, 5)[-1, 3] = bad
    with pytest.raises(ValueError, match="x .*not finite"):
        model.step(x, u, 0.05, 2)
    with pytest.raises(ValueError, match="x .*not finite"):
        model.derivative(x, u)
    x.reshape(-1, 5)[-1, 3] = 0.0
    u.reshape(-1, 4)[-1, 2] = bad
    with pytest.raises(ValueError, match="u .*not finite"):
        model.step(x, u, 0.05, 2)
    with pytest.raises(ValueError, match="u .*not finite"):
        model.derivative(x, u)


@pytest.mark.parametrize("dt", [0.0, -0.05, np.nan, np.inf])
@pytest.mark.parametrize("x", [X0, X0[None]])
def test_bad_dt(model, dt, x):
    with pytest.raises(ValueError, match="dt"):
        model.step(x, U0, dt)


@pytest.mark.parametrize("x", [X0, X0[None]])
def test_bad_substeps(model, x):
    for n in (0, -3):
        with pytest.raises(ValueError, match="n_substeps"):
            model.step(x, U0, 0.05, n)
    for n in (2.5, 2.0, True, "4"):
        with pytest.raises(TypeError, match="n_substeps"):
            model.step(x, U0, 0.05, n)
    with pytest.raises(TypeError, match="dt"):
        model.step(x, U0, "0.05")


def test_divergence_raises_instead_of_nan(model):
    # lambda dt far outside RK4's stability region: the state overflows, step raises
    for x in (X0, X0[None]):
        with pytest.raises(FloatingPointError, match="non-finite"):
            model.step(x, U0, 1e4, 50)


def test_model_n_substeps(model):
    assert model.n_substeps() == round(model.default_ctrl_dt / model.default_sim_dt)
    assert model.n_substeps(0.1, 0.001) == 100
    with pytest.raises(ValueError, match="whole multiple"):
        model.n_substeps(0.05, 0.003)
    with pytest.raises(ValueError, match="sim_dt"):
        model.n_substeps(0.05, 0.0)


def test_read_only_inputs_step_through_the_writable_signature(model):
    """Read-only inputs (broadcast views, frozen arrays) reach the kernels as writable copies,
    with the same result: numba would compile each kernel again for read-only arrays."""
    from tests.kernel_signatures import read_only_arrays

    x = np.zeros((3, 5))
    x[:, 3:] = 0.2
    u = np.full(4, 1.5)
    expected = model.step(x, u, 0.01, 2)
    frozen_x, frozen_u = x.copy(), u.copy()
    frozen_x.flags.writeable = frozen_u.flags.writeable = False
    for xs, us in ((frozen_x, frozen_u), (np.broadcast_to(x[0], (3, 5)), u),
                   (frozen_x[0], frozen_u)):
        got = model.step(xs, us, 0.01, 2)
        np.testing.assert_array_equal(got, expected[: len(got)] if got.ndim == 2 else expected[0])
        model.derivative(xs, us)
    for kernel in (type(model)._k_step, type(model)._k_deriv):
        assert not read_only_arrays(kernel), kernel.signatures
