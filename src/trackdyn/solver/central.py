"""Central differences with Newton-Raphson at every step (seed eqs 5.15-5.18).

The one compiled time-stepping loop of trackdyn. With ``A = M/Δt² + C/(2Δt)`` the scheme

    A q1 = (2M/Δt² - K) q0 - (M/Δt² - C/(2Δt)) q-1 - Dc^T f(q0, t0) - Dw^T F(v0, d0)

is explicit in the springs and the contact forces (evaluated at ``q0``, as 5.18 does with
``k2(y2(0), x)``) and implicit in the dampers and in the wedge friction, whose velocity
``v0 = Dw (q1 - q-1) / (2Δt)`` depends on ``q1``. ``A`` is constant, so its inverse is
formed once; each step then solves only the small nonlinear system of the wedges,

    v + H F(v) = v_free,    H = Dw A^-1 Dw^T / (2Δt),

by Newton-Raphson. ``F`` is piecewise linear and monotone in ``v`` (eqs 5.30-5.33), so
Newton ends in a few iterations once the stick/slip state of every wedge is right.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, inline="always")
def wedge_law(v, f_up, f_down, c_slope):
    """Friction force [N] and its slope dF/dv [N s/m] at relative velocity ``v`` [m/s].

    ``f_up``/``f_down`` are the slip forces in compression/extension (5.30); near zero
    velocity the force follows ``C_slope v`` while that is smaller in magnitude.
    """
    f = c_slope * v
    if f > f_up:
        return f_up, 0.0
    if f < -f_down:
        return -f_down, 0.0
    return f, c_slope


@njit(cache=True, inline="always", error_model="numpy")
def _solve_small(a, b, n):
    """Solve ``a x = b`` in place (Gaussian elimination, partial pivoting); returns ``b``."""
    for k in range(n):
        p = k
        for i in range(k + 1, n):
            if abs(a[i, k]) > abs(a[p, k]):
                p = i
        if p != k:
            for j in range(n):
                a[k, j], a[p, j] = a[p, j], a[k, j]
            b[k], b[p] = b[p], b[k]
        for i in range(k + 1, n):
            m = a[i, k] / a[k, k]
            for j in range(k, n):
                a[i, j] -= m * a[k, j]
            b[i] -= m * b[k]
    for k in range(n - 1, -1, -1):
        s = b[k]
        for j in range(k + 1, n):
            s -= a[k, j] * b[j]
        b[k] = s / a[k, k]
    return b


@njit(cache=True)
def contact_table_force(table, y_start, y_step, deflection):
    """Tabulated track force [N] at ``deflection`` [m]: zero before the table, linear after."""
    if deflection <= y_start:
        return 0.0
    u = (deflection - y_start) / y_step
    j = int(u)
    last = table.size - 1
    if j >= last:
        return table[last] + (u - last) * (table[last] - table[last - 1])
    return table[j] + (u - j) * (table[j + 1] - table[j])


@njit(cache=True, fastmath=True, error_model="numpy")
def integrate_chunk(
    P1t, P2t, Gct, Gwt, Dc, Dw, H, wedge, static_load,
    k_in, r_in, table, y_start, y_step,
    q0, qm1, dt, step0, store_every, tol, max_iter,
    out_q, out_v, out_a, out_fc, out_fw, out_vw,
):  # fmt: skip
    """Advance ``k_in.shape[0]`` steps from ``(q-1, q0)``; update them in place.

    Contacts are linear, ``f = k (Dc q - r)``, when ``table`` has no rows, and tabulated
    (``f = P(Dc q - r) - Ps``) otherwise. Every ``store_every``-th global step is written
    to the ``out_*`` arrays (displacement, velocity, acceleration, contact force beyond
    static without damping, wedge force, wedge velocity).

    Returns -1 on success, or the chunk-local index of the step whose Newton iteration
    did not converge.
    """
    n = q0.size
    nc = Dc.shape[0]
    nw = Dw.shape[0]
    inv2dt = 0.5 / dt
    invdt2 = 1.0 / (dt * dt)
    nonlinear = table.shape[0] > 0
    q1 = np.empty(n)
    fc = np.empty(nc)
    vfree = np.empty(nw)
    v = np.empty(nw)
    f_up = np.empty(nw)
    f_down = np.empty(nw)
    F = np.zeros(nw)
    dF = np.empty(nw)
    jac = np.empty((nw, nw))
    res = np.empty(nw)
    stored = 0
    for s in range(k_in.shape[0]):
        for c in range(nc):
            x = 0.0
            for i in range(n):
                x += Dc[c, i] * q0[i]
            if nonlinear:
                fc[c] = contact_table_force(table[s, c], y_start, y_step, x - r_in[s, c])
                fc[c] -= static_load
            else:
                fc[c] = k_in[s, c] * (x - r_in[s, c])
        # column sweeps over the transposed matrices: independent updates, no long chains
        for i in range(n):
            q1[i] = 0.0
        for j in range(n):
            a = q0[j]
            b = qm1[j]
            for i in range(n):
                q1[i] += P1t[j, i] * a - P2t[j, i] * b
        for c in range(nc):
            f = fc[c]
            for i in range(n):
                q1[i] -= Gct[c, i] * f
        if nw > 0:
            for w in range(nw):
                dd = 0.0
                vv = 0.0
                for i in range(n):
                    dd += Dw[w, i] * q0[i]
                    vv += Dw[w, i] * (q1[i] - qm1[i])
                vfree[w] = vv * inv2dt
                v[w] = vfree[w]
                normal = (wedge[w, 1] + dd) * wedge[w, 0]
                if normal < 0.0:
                    normal = 0.0
                f_up[w] = normal * wedge[w, 2] / (wedge[w, 3] - wedge[w, 2])
                f_down[w] = normal * wedge[w, 2] / (wedge[w, 3] + wedge[w, 2])
            converged = False
            for _ in range(max_iter):
                for w in range(nw):
                    F[w], dF[w] = wedge_law(v[w], f_up[w], f_down[w], wedge[w, 4])
                size = 0.0
                for w in range(nw):
                    r = v[w] - vfree[w]
                    for u in range(nw):
                        r += H[w, u] * F[u]
                        jac[w, u] = H[w, u] * dF[u]
                    jac[w, w] += 1.0
                    res[w] = -r
                    size = max(size, abs(v[w]))
                _solve_small(jac, res, nw)
                step = 0.0
                for w in range(nw):
                    v[w] += res[w]
                    step = max(step, abs(res[w]))
                if step <= tol * (1.0 + size):
                    converged = True
                    break
            if not converged:
                return s
            for w in range(nw):
                F[w], dF[w] = wedge_law(v[w], f_up[w], f_down[w], wedge[w, 4])
            for w in range(nw):
                f = F[w]
                for i in range(n):
                    q1[i] -= Gwt[w, i] * f
        if (step0 + s) % store_every == 0:
            for i in range(n):
                out_q[stored, i] = q0[i]
                out_v[stored, i] = (q1[i] - qm1[i]) * inv2dt
                out_a[stored, i] = (q1[i] - 2.0 * q0[i] + qm1[i]) * invdt2
            for c in range(nc):
                out_fc[stored, c] = fc[c]
            for w in range(nw):
                out_fw[stored, w] = F[w]
                out_vw[stored, w] = v[w]
            stored += 1
        for i in range(n):
            qm1[i] = q0[i]
            q0[i] = q1[i]
    return -1


def step_matrices(M, C, K, Dc, Dw, dt):
    """Constant matrices of the scheme, transposed for the loop: ``P1^T, P2^T, Gc^T, Gw^T``
    and ``H`` (see the module docstring)."""
    A = M / dt**2 + C / (2 * dt)
    Ainv = np.linalg.inv(A)
    P1 = Ainv @ (2 * M / dt**2 - K)
    P2 = Ainv @ (M / dt**2 - C / (2 * dt))
    Gc = Ainv @ Dc.T
    Gw = Ainv @ Dw.T
    H = Dw @ Gw / (2 * dt)
    return (*(np.ascontiguousarray(x.T) for x in (P1, P2, Gc, Gw)), H)


def highest_frequency(M, K) -> float:
    """Highest undamped natural angular frequency of ``(K, M)`` [rad/s]."""
    m = np.diag(M)
    scaled = K / np.sqrt(np.outer(m, m))
    return float(np.sqrt(max(np.linalg.eigvalsh(scaled).max(), 0.0)))


STEPS_PER_PERIOD = 50
"""Default Δt gives this many steps per period of the highest natural frequency: the
central-difference period error is about (ωΔt)²/24 = 0.07 %."""
