"""The exact linear-phase integral of a flat polygon (Gordon's edge sum) against closed forms and quadrature."""

from __future__ import annotations

import numpy as np
import pytest

from sionnafmcw.polygon_integral import SERIES_RADIUS, PolygonError, polygon_phase_integral

A, B = 0.1, 0.06
OFFSET = np.array([0.01, 0.02, 0.3])
RECT = np.array([[-A / 2, -B / 2, 0], [A / 2, -B / 2, 0], [A / 2, B / 2, 0], [-A / 2, B / 2, 0]]) + OFFSET
TRIANGLE = np.array([[0.0, 0.0, 0.0], [0.08, 0.01, 0.02], [0.03, 0.07, -0.01]]) + [1.0, -0.5, 2.0]


def rect_closed_form(w):
    """ab sinc(w_x a/2) sinc(w_y b/2) e^{j w.c}: the Fourier transform of the rectangle."""
    w = np.atleast_2d(w)
    return A * B * np.sinc(w[:, 0] * A / 2 / np.pi) * np.sinc(w[:, 1] * B / 2 / np.pi) * np.exp(1j * w @ OFFSET)


def triangle_quadrature(tri, w, n=160):
    """Gauss-Legendre on the square mapped onto the triangle (Duffy): exact for polynomials of degree
    2n - 1 in each variable, so its error falls faster than any power once n exceeds the phase across
    the triangle (here <= 40 rad with n = 160)."""
    x, wx = np.polynomial.legendre.leggauss(n)
    u, wu = (x + 1) / 2, wx / 2
    uu, vv = np.meshgrid(u, u, indexing="ij")
    ww = np.outer(wu, wu) * (1 - uu)                        # Jacobian of (u, v) -> (u, (1 - u) v)
    s, t = uu, (1 - uu) * vv
    e1, e2 = tri[1] - tri[0], tri[2] - tri[0]
    area2 = np.linalg.norm(np.cross(e1, e2))
    p = tri[0] + s[..., None] * e1 + t[..., None] * e2
    return np.sum(ww * np.exp(1j * p @ w)) * area2


def test_rectangle_is_sinc_times_sinc():
    rng = np.random.default_rng(1)
    w = np.concatenate([[[0, 0, 5], [30, 0, 1], [0, 40, 2], [1e-7, -3e-7, 9]],
                        rng.normal(scale=[300, 300, 100], size=(50, 3))])
    got = polygon_phase_integral(RECT, w)
    # the closed form is exact: the difference is rounding, relative to the area
    np.testing.assert_allclose(got, rect_closed_form(w), rtol=0, atol=1e-13 * A * B)
    assert polygon_phase_integral(RECT[::-1], w) == pytest.approx(got, abs=1e-13 * A * B)   # order's sense


def test_triangle_against_quadrature():
    rng = np.random.default_rng(2)
    w = rng.normal(scale=200.0, size=(20, 3))
    got = polygon_phase_integral(TRIANGLE, w)
    area = 0.5 * np.linalg.norm(np.cross(TRIANGLE[1] - TRIANGLE[0], TRIANGLE[2] - TRIANGLE[0]))
    ref = np.array([triangle_quadrature(TRIANGLE, wi) for wi in w])
    coarse = np.array([triangle_quadrature(TRIANGLE, wi, n=80) for wi in w])
    assert np.max(np.abs(ref - coarse)) < 1e-12 * area     # the quadrature's own error, by doubling n
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-12 * area)


def test_non_convex_polygon_is_the_sum_of_its_parts():
    ell = np.array([[0, 0, 0], [0.1, 0, 0], [0.1, 0.03, 0], [0.03, 0.03, 0], [0.03, 0.08, 0], [0, 0.08, 0]], float)
    lower = np.array([[0, 0, 0], [0.1, 0, 0], [0.1, 0.03, 0], [0, 0.03, 0]], float)
    upper = np.array([[0, 0.03, 0], [0.03, 0.03, 0], [0.03, 0.08, 0], [0, 0.08, 0]], float)
    rng = np.random.default_rng(3)
    for w in np.concatenate([rng.normal(scale=150.0, size=(10, 3)), [[1e-4, 2e-4, 7.0]]]):
        assert polygon_phase_integral(ell, w) == pytest.approx(
            polygon_phase_integral(lower, w) + polygon_phase_integral(upper, w), abs=1e-13 * 0.0045)


def test_area_at_zero_and_continuity_through_the_series_switch():
    w_n = np.array([0.0, 0.0, 11.0])
    centre = RECT.mean(axis=0)
    assert polygon_phase_integral(RECT, w_n) == pytest.approx(A * B * np.exp(1j * w_n @ centre), abs=1e-16)
    radius = np.max(np.linalg.norm(RECT - centre, axis=1))
    direction = np.array([0.6, 0.8, 0.0])
    for scale in (1e-9, 1e-5, 1e-2):
        small = polygon_phase_integral(RECT, w_n + scale * direction)
        assert small == pytest.approx(rect_closed_form(w_n + scale * direction)[0], abs=1e-15 * A * B)
    # the two forms on either side of |w_t| rho = SERIES_RADIUS (series below, edge sum above): both on the
    # closed form to rounding, so the switch leaves no step
    for x in (SERIES_RADIUS * (1 - 1e-12), SERIES_RADIUS * (1 + 1e-12), 2 * SERIES_RADIUS):
        w = w_n + x / radius * direction
        assert polygon_phase_integral(RECT, w) == pytest.approx(rect_closed_form(w)[0], abs=2e-15 * A * B)


@pytest.mark.parametrize("along", [True, False], ids=["w_t-along-an-edge", "w_t-across-an-edge"])
def test_continuity_through_w_parallel_or_perpendicular_to_an_edge(along):
    """Gordon's vertex form divides by w.e_k: singular where w_t is perpendicular to an edge. The edge sum
    is smooth there; near and at that direction it stays on the quadrature."""
    edge = TRIANGLE[1] - TRIANGLE[0]
    normal = np.cross(edge, TRIANGLE[2] - TRIANGLE[0])
    normal /= np.linalg.norm(normal)
    t = edge / np.linalg.norm(edge)
    across = np.cross(normal, t)
    base = t if along else across
    area = 0.5 * np.linalg.norm(np.cross(edge, TRIANGLE[2] - TRIANGLE[0]))
    for delta in (0.0, 1e-12, 1e-8, 1e-4):
        w = 250.0 * (base + delta * (across if along else t)) + 30.0 * normal
        assert polygon_phase_integral(TRIANGLE, w) == pytest.approx(triangle_quadrature(TRIANGLE, w), abs=1e-12 * area)


def test_bad_input_names_the_parameter():
    with pytest.raises(PolygonError, match="vertices must have shape"):
        polygon_phase_integral(np.zeros((2, 3)), [0, 0, 1])
    with pytest.raises(PolygonError, match="w must have shape"):
        polygon_phase_integral(RECT, [0, 1])
    assert polygon_phase_integral(np.zeros((3, 3)), [1.0, 2.0, 3.0]) == 0       # degenerate: no area
