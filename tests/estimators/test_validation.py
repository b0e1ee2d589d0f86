"""Input validation of ``fit``, ``fit_lti``, ``Prior`` and ``OutputPrior``.

Every bad input raises ValueError or TypeError whose message starts with the
name of the offending argument; list/pandas inputs give the same result as
arrays; inputs are never mutated and never aliased by the returned model.
"""

from __future__ import annotations

import signal
import time

import numpy as np
import pandas as pd
import pytest
from dense_reference import random_data

import ltvmodels as ltv

T, n, m = 30, 2, 1
N, K = T - 1, n * (n + m)


@pytest.fixture(scope="module")
def data():
    return random_data(61, T, n, m)


def _with_nan(a, value=np.nan):
    a = a.copy()
    a[3, 0] = value
    return a


def _spd(d, seed=0):
    G = np.random.default_rng(seed).standard_normal((d, d))
    return G @ G.T + d * np.eye(d)


ASYM = np.eye(K) + np.triu(np.ones((K, K)), 1) * 0.1
INDEF = np.diag([1.0, 1, 1, 1, 1, -1])

# (id, kwargs overriding x/u/lam, exception, regex the message must match)
BAD_FIT_INPUTS = [
    ("x-neginf", dict(x=lambda x, u: _with_nan(x, -np.inf)), ValueError, r"^x: expected finite"),
    ("x-inf", dict(x=lambda x, u: _with_nan(x, np.inf)), ValueError, r"^x: expected finite"),
    ("u-inf", dict(u=lambda x, u: _with_nan(u, np.inf)), ValueError, r"^u: expected finite"),
    ("u-neginf", dict(u=lambda x, u: _with_nan(u, -np.inf)), ValueError, r"^u: expected finite"),
    ("u-short", dict(u=lambda x, u: u[:-1]), ValueError, r"^u: expected 30 rows"),
    ("u-long", dict(u=lambda x, u: np.vstack([u, u[:1]])), ValueError, r"^u: expected 30 rows"),
    ("x-4d", dict(x=lambda x, u: x[None, None]), ValueError, r"^x: expected shape \(T, d\)"),
    ("u-4d", dict(u=lambda x, u: u[None, None]), ValueError, r"^u: expected shape \(T, d\)"),
    ("u-batch-of-2", dict(u=lambda x, u: np.stack([u, u])), ValueError, r"^u: expected \d+ rows"),
    ("x-str", dict(x=lambda x, u: "abc"), TypeError, r"^x:"),
    ("x-numeric-strings", dict(x=lambda x, u: x.astype(str)), TypeError, r"^x:"),
    ("u-numeric-strings", dict(u=lambda x, u: [str(v) for v in u[:, 0]]), TypeError, r"^u:"),
    ("x-words", dict(x=lambda x, u: [["a", "b"]] * T), TypeError, r"^x:"),
    ("u-str", dict(u=lambda x, u: "abc"), TypeError, r"^u:"),
    ("x-none", dict(x=lambda x, u: None), TypeError, r"^x:"),
    ("x-ragged", dict(x=lambda x, u: [[1.0, 2.0], [3.0]] * 15), TypeError, r"^x:"),
    ("x-complex", dict(x=lambda x, u: x + 1j), TypeError, r"^x:"),
    (
        "x-no-columns",
        dict(x=lambda x, u: np.zeros((T, 0)), u=lambda x, u: None),
        ValueError,
        r"^x:",
    ),
    ("x-one-sample", dict(x=lambda x, u: x[:1], u=lambda x, u: None), ValueError, r"^x:"),
    ("x-empty", dict(x=lambda x, u: np.zeros((0, 2)), u=lambda x, u: None), ValueError, r"^x:"),
    (
        "too-few-samples",
        dict(x=lambda x, u: x[:3], u=lambda x, u: u[:3]),
        ValueError,
        r"^x: too few samples",
    ),
    (
        "too-few-samples-order2",
        dict(x=lambda x, u: x[:6], u=lambda x, u: u[:6], order=2),
        ValueError,
        r"^x: too few samples",
    ),
    ("order-too-high-for-data", dict(order=20), ValueError, r"^x: too few samples"),
    ("order-exceeds-samples", dict(order=100), ValueError, r"^order:.*at most 30"),
    ("lam-negative", dict(lam=-1.0), ValueError, r"^lam:"),
    ("lam-nan", dict(lam=np.nan), ValueError, r"^lam:"),
    ("lam-neginf", dict(lam=-np.inf), ValueError, r"^lam:"),
    ("lam-vector-nan", dict(lam=np.array([1, 2, np.nan, 1, 1, 1.0])), ValueError, r"^lam:.*NaN"),
    ("lam-vector-negative", dict(lam=np.array([1, 2, -1, 1, 1, 1.0])), ValueError, r"^lam:.*>= 0"),
    ("lam-vector-length", dict(lam=np.ones(5)), ValueError, r"^lam:.*length K=6"),
    ("lam-vector-length-long", dict(lam=np.ones(7)), ValueError, r"^lam:.*length K=6"),
    ("lam-matrix-asymmetric", dict(lam=ASYM), ValueError, r"^lam:.*symmetric"),
    ("lam-matrix-indefinite", dict(lam=INDEF), ValueError, r"^lam:.*semidefinite"),
    ("lam-matrix-shape", dict(lam=np.eye(5)), ValueError, r"^lam:.*\(6, 6\)"),
    ("lam-matrix-nonsquare", dict(lam=np.ones((6, 5))), ValueError, r"^lam:"),
    ("lam-matrix-inf", dict(lam=np.diag([1.0, 1, 1, 1, 1, np.inf])), ValueError, r"^lam:"),
    ("lam-matrix-nan", dict(lam=np.where(np.eye(K) > 0, 1.0, np.nan)), ValueError, r"^lam:"),
    ("lam-3d", dict(lam=np.ones((2, 2, 2))), ValueError, r"^lam:"),
    ("lam-str", dict(lam="1.0"), TypeError, r"^lam:"),
    ("lam-words", dict(lam=["a"] * K), TypeError, r"^lam:"),
    ("lam-none", dict(lam=None), TypeError, r"^lam:"),
    ("lam-bool", dict(lam=True), TypeError, r"^lam:"),
    ("lam-complex", dict(lam=1j), TypeError, r"^lam:"),
    ("norm-unknown", dict(norm="foo"), ValueError, r"^norm:.*'sq'"),
    ("norm-case", dict(norm="SQ"), ValueError, r"^norm:"),
    ("norm-none", dict(norm=None), ValueError, r"^norm:"),
    ("norm-number", dict(norm=2), ValueError, r"^norm:"),
    ("order-zero", dict(order=0), ValueError, r"^order:.*>= 1"),
    ("order-negative", dict(order=-2), ValueError, r"^order:.*>= 1"),
    ("order-float", dict(order=1.0), TypeError, r"^order:"),
    ("order-float-frac", dict(order=1.5), TypeError, r"^order:"),
    ("order-true", dict(order=True), TypeError, r"^order:"),
    ("order-false", dict(order=False), TypeError, r"^order:"),
    ("order-none", dict(order=None), TypeError, r"^order:"),
    ("order-word", dict(order="ab"), TypeError, r"^order:"),
    ("order-numeric-string", dict(order="2"), TypeError, r"^order:"),
    ("order-not-summing-to-zero", dict(order=[1, -2, 2]), ValueError, r"^order:.*sum to zero"),
    ("order-poly-not-zero-sum", dict(order=[-1, 3, -3, 2]), ValueError, r"^order:.*sum to zero"),
    ("order-leading-zero", dict(order=[0, -1, 1]), ValueError, r"^order:.*nonzero"),
    ("order-trailing-zero", dict(order=[1, -1, 0]), ValueError, r"^order:.*nonzero"),
    ("order-single", dict(order=[1.0]), ValueError, r"^order:"),
    ("order-2d", dict(order=[[-1, 1]]), ValueError, r"^order:"),
    ("order-nan", dict(order=[np.nan, 1.0]), ValueError, r"^order:"),
    ("prior-mode", dict(prior_mode="fast"), ValueError, r"^prior_mode:.*'exact'"),
    ("prior-mode-none", dict(prior_mode=None), ValueError, r"^prior_mode:"),
    ("noise-var-zero", dict(noise_var=0.0), ValueError, r"^noise_var:.*> 0"),
    ("noise-var-negative", dict(noise_var=-1.0), ValueError, r"^noise_var:.*> 0"),
    ("noise-var-nan", dict(noise_var=np.nan), ValueError, r"^noise_var:"),
    ("noise-var-inf", dict(noise_var=np.inf), ValueError, r"^noise_var:"),
    ("noise-var-str", dict(noise_var="1"), TypeError, r"^noise_var:"),
    ("noise-var-3", dict(noise_var=[1.0, 2.0, 3.0]), ValueError, r"^noise_var: expected a "),
    ("noise-var-negative", dict(noise_var=[1.0, -2.0]), ValueError, r"^noise_var: expected a "),
    ("noise-var-bool", dict(noise_var=True), TypeError, r"^noise_var:"),
    ("compute-cov-int", dict(compute_cov=1), TypeError, r"^compute_cov:"),
    ("compute-cov-str", dict(compute_cov="yes"), TypeError, r"^compute_cov:"),
    ("prior-str", dict(prior="abc"), TypeError, r"^prior:"),
    ("prior-dict", dict(prior={"mean": 0}), TypeError, r"^prior:"),
    ("prior-list-junk", dict(prior=[ltv.Prior(np.zeros(K), 1.0), 1.0]), TypeError, r"^prior:"),
    (
        "prior-mean-length",
        dict(prior=ltv.Prior(np.zeros(K - 1), 1.0)),
        ValueError,
        r"^prior\.mean:.*\(6,\)",
    ),
    (
        "prior-mean-rows",
        dict(prior=ltv.Prior(np.zeros((N + 1, K)), 1.0)),
        ValueError,
        r"^prior\.mean:.*\(29, 6\)",
    ),
    (
        "prior-cov-shape",
        dict(prior=ltv.Prior(np.zeros(K), np.eye(K - 1))),
        ValueError,
        r"^prior\.cov:",
    ),
    (
        "prior-cov-rows",
        dict(prior=ltv.Prior(np.zeros(K), np.ones((N + 1, K, K)))),
        ValueError,
        r"^prior\.cov:",
    ),
    (
        "prior-cov-indefinite",
        dict(prior=ltv.Prior(np.zeros(K), INDEF)),
        ValueError,
        r"^prior\.cov:.*positive definite",
    ),
    (
        "prior-cov-singular",
        dict(prior=ltv.Prior(np.zeros(K), np.diag([1.0, 1, 1, 1, 1, 0]))),
        ValueError,
        r"^prior\.cov:.*positive definite",
    ),
    (
        "prior-cov-asymmetric",
        dict(prior=ltv.Prior(np.zeros(K), ASYM)),
        ValueError,
        r"^prior\.cov:.*symmetric",
    ),
    ("prior-cov-negative", dict(prior=ltv.Prior(np.zeros(K), -1.0)), ValueError, r"^prior\.cov:"),
    ("prior-cov-zero", dict(prior=ltv.Prior(np.zeros(K), 0.0)), ValueError, r"^prior\.cov:"),
    (
        "prior-cov-time-indefinite",
        dict(
            prior=ltv.Prior(
                np.zeros(K),
                np.concatenate([np.broadcast_to(np.eye(K), (N - 1, K, K)), INDEF[None]]),
            )
        ),
        ValueError,
        r"^prior\.cov:.*positive definite",
    ),
    (
        "output-prior-mean",
        dict(prior=ltv.OutputPrior(np.zeros(3), 1.0)),
        ValueError,
        r"output prior mean",
    ),
    (
        "output-prior-cov",
        dict(prior=ltv.OutputPrior(np.zeros(2), -np.eye(2))),
        ValueError,
        r"output prior cov",
    ),
    (
        "output-prior-cov-shape",
        dict(prior=ltv.OutputPrior(np.zeros(2), np.eye(3))),
        ValueError,
        r"output prior cov",
    ),
]


@pytest.mark.parametrize(
    "kwargs, exc, pattern", [c[1:] for c in BAD_FIT_INPUTS], ids=[c[0] for c in BAD_FIT_INPUTS]
)
def test_bad_fit_input_raises_naming_the_argument(data, kwargs, exc, pattern):
    x, u = data
    kwargs = dict(kwargs)
    xx = kwargs.pop("x")(x, u) if "x" in kwargs else x
    uu = kwargs.pop("u")(x, u) if "u" in kwargs else u
    kwargs.setdefault("lam", 1.0)
    with pytest.raises(exc, match=pattern):
        ltv.fit(xx, uu, **kwargs)


def test_prior_from_a_different_system_names_prior_mean(data):
    x, u = data
    other = ltv.fit(x, u, lam=1.0)  # K = 6
    with pytest.raises(ValueError, match=r"^prior\.mean:"):
        ltv.fit(x[:, :1], None, lam=1.0, prior=ltv.Prior(other, 1.0))


@pytest.mark.parametrize("norm", ["group", "l1"])
def test_sparse_norms_reject_what_they_do_not_support(data, norm):
    x, u = data
    K = x.shape[1] * (x.shape[1] + u.shape[1])
    with pytest.raises(ValueError, match=r"^lam:.*ill-posed"):
        ltv.fit(x, u, lam=0.0, norm=norm)
    with pytest.raises(ValueError, match=r"^lam:.*norm='sq' only"):
        ltv.fit(x, u, lam=np.eye(K), norm=norm)
    mixed = np.ones(K)
    mixed[0], mixed[1] = np.inf, 0.0  # constants need every weight > 0
    with pytest.raises(NotImplementedError, match=r"^lam:.*inf"):
        ltv.fit(x, u, lam=mixed, norm=norm)
    with pytest.raises(NotImplementedError, match=r"^prior:"):
        ltv.fit(x, u, lam=1.0, norm=norm, prior=ltv.Prior(np.zeros(K), 1.0))
    with pytest.raises(ValueError, match=r"^max_iter:"):
        ltv.fit(x, u, lam=1.0, norm=norm, max_iter=0)
    with pytest.raises(ValueError, match=r"^tol:"):
        ltv.fit(x, u, lam=1.0, norm=norm, tol=-1.0)


class _TookTooLong(Exception):
    pass


def test_huge_integer_order_is_rejected_quickly(data):
    """order=10**6 must fail fast (building 10**6 binomial coefficients would hang)."""
    x, u = data

    def alarm(signum, frame):
        raise _TookTooLong("fit(order=10**6) did not return within 5 s")

    use_alarm = hasattr(signal, "SIGALRM")
    if use_alarm:
        previous = signal.signal(signal.SIGALRM, alarm)
        signal.alarm(5)
    start = time.perf_counter()
    try:
        with pytest.raises(ValueError, match=r"^order:"):
            ltv.fit(x, u, lam=1.0, order=10**6)
    finally:
        if use_alarm:
            signal.alarm(0)
            signal.signal(signal.SIGALRM, previous)
    if not use_alarm:  # the alarm above stops a hang; without it, time the call
        assert time.perf_counter() - start < 5.0


def test_lam_is_required(data):
    x, u = data
    with pytest.raises(TypeError, match="lam"):
        ltv.fit(x, u)  # type: ignore[call-arg]


@pytest.mark.parametrize(
    "make, exc, pattern",
    [
        (lambda: ltv.Prior(np.zeros((N, K, 1)), 1.0), ValueError, r"^mean:"),
        (lambda: ltv.Prior(np.full(K, np.nan), 1.0), ValueError, r"^mean: expected finite"),
        (lambda: ltv.Prior("abc", 1.0), TypeError, r"^mean:"),
        (lambda: ltv.Prior(np.zeros(K), np.ones(K)), ValueError, r"^cov:"),
        (lambda: ltv.Prior(np.zeros(K), np.full((K, K), np.nan)), ValueError, r"^cov:"),
        (lambda: ltv.Prior(np.zeros(K), None), TypeError, r"^cov:"),
        (lambda: ltv.OutputPrior(np.zeros((N, n, 1)), 1.0), ValueError, r"^mean:"),
        (lambda: ltv.OutputPrior(np.zeros(n), np.ones(n)), ValueError, r"^cov:"),
        (lambda: ltv.OutputPrior(np.zeros(n), np.inf), ValueError, r"^cov:"),
    ],
)
def test_bad_prior_construction(make, exc, pattern):
    with pytest.raises(exc, match=pattern):
        make()


@pytest.mark.parametrize(
    "xf, uf, pattern",
    [
        (lambda x: _with_nan(x, np.inf), lambda u: u, r"^x: expected finite"),
        (lambda x: x, lambda u: u[:-2], r"^u: expected 30 rows"),
        (lambda x: x[:3], lambda u: u[:3], r"^x: too few samples"),
        (lambda x: x[None, None], lambda u: u, r"^x: expected shape \(T, d\)"),
    ],
)
def test_bad_fit_lti_input(data, xf, uf, pattern):
    x, u = data
    with pytest.raises(ValueError, match=pattern):
        ltv.fit_lti(xf(x), uf(u))


# -- equivalent input types -------------------------------------------------------------------


def test_lists_and_pandas_give_the_same_model(data):
    x, u = data
    lam = np.linspace(0.5, 2.0, K)
    ref = ltv.fit(x, u, lam=lam, order=2)
    variants = [
        (x.tolist(), u.tolist(), lam.tolist()),
        (pd.DataFrame(x, columns=["a", "b"]), pd.DataFrame(u, columns=["f"]), pd.Series(lam)),
        (pd.DataFrame(x), pd.Series(u[:, 0]), tuple(lam)),
        (x, u[:, 0], lam),  # (T,) input
        (np.asfortranarray(x), np.asfortranarray(u), lam),
    ]
    for xx, uu, ll in variants:
        model = ltv.fit(xx, uu, lam=ll, order=2)
        np.testing.assert_array_equal(model.k, ref.k)
        np.testing.assert_array_equal(model.cov_full(), ref.cov_full())
        assert model.loglik == ref.loglik


def test_noncontiguous_readonly_and_integer_inputs(data):
    x, u = data
    xs = np.repeat(x, 2, axis=0)[::2]  # non-contiguous view equal to x
    xs.flags.writeable = False
    a = ltv.fit(xs, u, lam=1.0)
    np.testing.assert_array_equal(a.k, ltv.fit(x, u, lam=1.0).k)
    xi = np.round(10 * x).astype(int)
    b = ltv.fit(xi, u, lam=1.0)
    np.testing.assert_array_equal(b.k, ltv.fit(xi.astype(float), u, lam=1.0).k)


def test_prior_inputs_as_lists_and_dataframes(data):
    x, u = data
    mean = np.linspace(-0.5, 0.5, K)
    cov = _spd(K) / 10
    a = ltv.fit(x, u, lam=1.0, prior=ltv.Prior(mean, cov), noise_var=0.5)
    b = ltv.fit(x, u, lam=1.0, prior=ltv.Prior(mean.tolist(), cov.tolist()), noise_var=0.5)
    c = ltv.fit(x, u, lam=1.0, prior=ltv.Prior(pd.Series(mean), pd.DataFrame(cov)), noise_var=0.5)
    np.testing.assert_array_equal(b.k, a.k)
    np.testing.assert_array_equal(c.k, a.k)


# -- no mutation, no aliasing -----------------------------------------------------------------


def _model_arrays(model):
    out = {
        "k": model.k,
        "A": model.A,
        "B": model.B,
        "theta": model.theta,
        "noise_cov": model.noise_cov,
        "lam": np.asarray(model.lam),
    }
    if model.cov is not None:
        out.update(cov=model.cov, cov_full=model.cov_full(), std=model.std())
    if model.coeffs is not None:
        out["coeffs"] = model.coeffs
    return out


@pytest.mark.parametrize("mode", ["exact", "posthoc"])
def test_inputs_are_not_mutated_nor_aliased(data, mode):
    x, u = data
    x, u = x.copy(), u.copy()
    lam = np.linspace(0.5, 2.0, K)
    order = np.array([1.0, -2.0, 1.0])
    mean = np.linspace(-0.5, 0.5, K)
    cov = _spd(K) / 10
    ybar, S = x[1:].copy(), 0.1 * np.eye(n)
    prior = ltv.Prior(mean, cov)
    oprior = ltv.OutputPrior(ybar, S)
    inputs = dict(
        x=x,
        u=u,
        lam=lam,
        order=order,
        mean=mean,
        cov=cov,
        ybar=ybar,
        S=S,
        prior_mean=prior.mean,
        prior_cov=prior.cov,
        oprior_mean=oprior.mean,
    )
    before = {key: value.copy() for key, value in inputs.items()}
    model = ltv.fit(
        x, u, lam=lam, order=order, prior=[prior, oprior], prior_mode=mode, noise_var=0.3
    )
    for key, value in inputs.items():
        np.testing.assert_array_equal(value, before[key], err_msg=key)
    arrays = _model_arrays(model)
    for name, arr in arrays.items():
        for key, value in inputs.items():
            assert not np.shares_memory(arr, value), f"model.{name} aliases input {key}"
    # mutating the inputs afterwards leaves the model unchanged
    snapshot = {name: np.array(arr, copy=True) for name, arr in arrays.items()}
    for value in inputs.values():
        value[...] = 7.0
    for name, arr in _model_arrays(model).items():
        np.testing.assert_array_equal(arr, snapshot[name], err_msg=name)


def test_matrix_lam_and_dataframe_not_mutated(data):
    x, u = data
    Lam = _spd(K) / K
    Lam_before = Lam.copy()
    df = pd.DataFrame(x)
    df_before = df.copy()
    model = ltv.fit(df, u, lam=Lam)
    np.testing.assert_array_equal(Lam, Lam_before)
    pd.testing.assert_frame_equal(df, df_before)
    assert not np.shares_memory(np.asarray(model.lam), Lam)


def test_fit_lti_does_not_alias(data):
    x, u = data
    x, u = x.copy(), u.copy()
    before = x.copy(), u.copy()
    model = ltv.fit_lti(x, u)
    np.testing.assert_array_equal(x, before[0])
    np.testing.assert_array_equal(u, before[1])
    for arr in _model_arrays(model).values():
        assert not np.shares_memory(arr, x) and not np.shares_memory(arr, u)
