#!/usr/bin/python3
"""An oracle for polar/uniaxial_fresnel that shares no code or formula with it.

polar/uniaxial_fresnel.c writes the crystal's waves in closed form (the o wave on the sphere
|K| = n_o, the e wave's quadratic, E_o ~ K x c, E_e ~ n_o^2 c - (K.c) K). This script finds
them the other way round, from Maxwell's equations alone: for a tangential wave vector
(kx, ky) the normal components q of the four crystal waves are the roots of the Booker
quartic det(K K^T - (K.K) I + eps) = 0, K = (kx, ky, q) (Born & Wolf §15.2; the quartic is
found here by sampling the determinant at five q and fitting, not by expanding it), each
wave's E is the null vector of that matrix (an SVD), H = K x E, a wave goes into the crystal
when its Poynting vector Re(E x H*) does (or, evanescent, when it decays into it), and the
four outgoing amplitudes follow from tangential E and H continuous (4 x 4, numpy.linalg).

Geometry: the outside medium (index n1) fills z < 0, the crystal z > 0 (so the C solver's m,
from the crystal toward the outside, is -z). Prints, for each case, the power fractions the
C test compares against (tests/unit/test_uniaxial.c, ORACLE_CASES):
    P(s -> s+p), P(s -> o), P(s -> e), P(p -> s+p), P(p -> o), P(p -> e),
    P(o -> s+p), P(o -> o), P(o -> e), P(e -> s+p), P(e -> o), P(e -> e)
with s = (t x m) / |t x m| as the C solver takes it. Usage: uniaxial_oracle.py (prints the
table as C initialisers)."""
import numpy as np


def cross(a, b):
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def wave_matrix(K, eps):
    return np.outer(K, K) - (K @ K) * np.eye(3) + eps


def crystal_waves(kx, ky, eps):
    """The four (q, E, H) of the crystal for tangential (kx, ky)."""
    qs = np.array([-2.0, -1.0, 0.0, 1.0, 2.0])
    dets = [np.linalg.det(wave_matrix(np.array([kx, ky, q]), eps)) for q in qs]
    coeffs = np.polyfit(qs, dets, 4)
    roots = np.roots(coeffs)
    waves = []
    for q in roots:
        # Polish the root (Newton on the determinant) so the null vector is clean.
        for _ in range(5):
            f = np.linalg.det(wave_matrix(np.array([kx, ky, q], dtype=complex), eps))
            h = 1e-7
            fp = (np.linalg.det(wave_matrix(np.array([kx, ky, q + h], dtype=complex), eps)) -
                  np.linalg.det(wave_matrix(np.array([kx, ky, q - h], dtype=complex), eps))) / (2 * h)
            if fp != 0:
                q = q - f / fp
        if abs(q.imag) < 1e-9:
            q = complex(q.real, 0.0)
        K = np.array([kx, ky, q], dtype=complex)
        u, sv, vh = np.linalg.svd(wave_matrix(K, eps))
        E = vh[-1].conj()
        E = E / np.linalg.norm(E)
        H = cross(K, E)
        waves.append((q, K, E, H))
    return waves


def poynting_z(E, H):
    return np.real(cross(E, H.conj()))[2]


def solve(kx, ky, axis, no, ne, n1):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    eps = no * no * np.eye(3) + (ne * ne - no * no) * np.outer(axis, axis)
    waves = crystal_waves(kx, ky, eps)
    down, up = [], []  # into the crystal (+z) and out of it (-z)
    for w in waves:
        q, K, E, H = w
        if abs(q.imag) > 1e-9:
            (down if q.imag > 0 else up).append(w)
        else:
            (down if poynting_z(E, H) > 0 else up).append(w)
    assert len(down) == 2 and len(up) == 2, (kx, ky, [w[0] for w in waves])

    def label(w):  # o: K.K = n_o^2 (bilinear, so evanescent waves too)
        return 'o' if abs(w[1] @ w[1] - no * no) < 1e-6 else 'e'
    down = sorted(down, key=lambda w: label(w) != 'o')
    up = sorted(up, key=lambda w: label(w) != 'o')
    assert [label(w) for w in down] == ['o', 'e'] and [label(w) for w in up] == ['o', 'e']
    # Outside: s along t x m with m = -z, p = K x s / n1.
    t = np.array([kx, ky, 0.0])
    s = cross(t, np.array([0.0, 0.0, -1.0]))
    s = s / np.linalg.norm(s)
    b = n1 * n1 - kx * kx - ky * ky
    q1 = np.sqrt(complex(b))  # decaying into z < 0 when imaginary: -q1 for outgoing
    out_side = []
    for sign in (+1, -1):  # +1 incident toward the crystal, -1 leaving it
        q = sign * q1 if b > 0 else sign * q1  # b < 0: sign -1 gives exp(+kappa z) decay, z < 0
        K = np.array([kx, ky, q], dtype=complex)
        ws = []
        for E in (s.astype(complex), cross(K, s) / n1):
            ws.append((q, K, E, cross(K, E)))
        out_side.append(ws)
    inc_out, refl_out = out_side
    if b < 0:  # the outside waves leaving must decay away from the boundary (z < 0): Im q < 0
        q = -1j * np.sqrt(-b)
        K = np.array([kx, ky, q])
        refl_out = [(q, K, s.astype(complex), cross(K, s.astype(complex))),
                    (q, K, cross(K, s) / n1, cross(K, cross(K, s) / n1))]

    def tang(w):
        return np.array([w[2][0], w[2][1], w[3][0], w[3][1]])

    # Unknowns: outgoing outside s, p (z < 0 side), crystal o, e going +z.
    A = np.zeros((4, 4), complex)
    for j, w in enumerate(refl_out):
        A[:, j] = tang(w)
    for j, w in enumerate(down):
        A[:, 2 + j] = -tang(w)
    flux_out = [abs(poynting_z(w[2], w[3])) if abs(w[0].imag) < 1e-12 else 0.0
                for w in refl_out + down]
    incident = list(inc_out) + list(up)  # s, p from outside; o, e from inside
    P = np.zeros((4, 4))
    for i, w in enumerate(incident):
        rhs = -tang(w) if i < 2 else tang(w)
        x = np.linalg.solve(A, rhs)
        fin = abs(poynting_z(w[2], w[3]))
        prop = abs(w[0].imag) < 1e-12
        for j in range(4):
            P[i, j] = abs(x[j]) ** 2 * flux_out[j] / fin if prop and fin > 0 else 0.0
    return P


# The cases: (kx, ky, axis, n_o, n_e, n1). Calcite and rutile at general axes, near-grazing
# and past critical angles inside (mode conversion at total internal reflection).
CASES = [
    (0.30, 0.20, (0.3, 0.8, 0.52), 1.6584, 1.4864, 1.0),
    (0.85, 0.10, (0.0, 1.0, 0.0), 1.6584, 1.4864, 1.0),
    (0.70, 0.35, (0.0, 1.0, 0.0), 1.6584, 1.4864, 1.0),   # the prism's axis, tilted ray
    (1.20, 0.40, (0.0, 1.0, 0.0), 1.6584, 1.4864, 1.0),   # past the critical angle: TIR
    (1.30, 0.50, (0.5, 0.5, 0.7), 1.6584, 1.4864, 1.0),
    (0.999, 0.01, (0.2, 0.1, 0.97), 1.6584, 1.4864, 1.0),  # grazing outside
    (1.45, 0.20, (0.6, -0.3, 0.74), 1.6584, 1.4864, 1.0),  # e beyond its own surface?
    (2.00, 0.70, (0.1, 0.9, 0.42), 2.613, 2.909, 1.0),      # rutile
    (0.50, -0.40, (0.7, 0.1, -0.7), 1.5443, 1.5534, 1.33),  # quartz under water
]


def oracle_row(case):
    kx, ky, axis, no, ne, n1 = case
    P = solve(kx, ky, axis, no, ne, n1)
    row = []
    for i in range(4):
        row += [P[i, 0] + P[i, 1], P[i, 2], P[i, 3]]
    return row


if __name__ == '__main__':
    for c in CASES:
        kx, ky, axis, no, ne, n1 = c
        row = oracle_row(c)
        a = np.asarray(axis, float) / np.linalg.norm(axis)
        print('    {%.17g, %.17g, {%.17g, %.17g, %.17g}, %.17g, %.17g, %.17g,' %
              (kx, ky, a[0], a[1], a[2], no, ne, n1))
        print('     {' + ', '.join('%.12e' % v for v in row) + '}},')
