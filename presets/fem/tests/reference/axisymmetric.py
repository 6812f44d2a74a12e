#!/usr/bin/env python3
"""Independent reference frequencies for the bank builder's solids of revolution.

Free vibration of a 3-D isotropic elastic solid of revolution, by Fourier harmonics in the
angle: the displacement of harmonic n is

    u_r = U(r, z) cos(n theta),  u_theta = V(r, z) sin(n theta),  u_z = W(r, z) cos(n theta),

so each n is a 2-D problem on the meridian section (full 3-D elasticity, no shell or plate
theory). The section is meshed by tensor-product Lagrange elements of order P on
Gauss-Lobatto nodes, mapped exactly onto the section (a rectangle in (r, z) for the disc, an
annular sector in (rho, phi) for the bowl and the spherical shell), and solved with
scipy's shift-invert Lanczos (ARPACK). Nothing here is shared with the Rust builder, whose
10-node tetrahedra mesh the whole 3-D solid: different elements, mesh, assembly and
eigensolver.

Self-tests against closed forms (run with --self-test; `--check` runs them too):
- torsional modes of a free spherical shell (degree l = 2 and 3), traction-free roots of
  (l - 1) z_l(x) - x z_{l+1}(x) with z = j, y (spherical Bessel functions), found in every
  harmonic n <= l;
- the breathing mode (l = 0) of the same shell, roots of (lam + 2 mu) k z_0(kr) - 4 mu z_1(kr)/r;
- the lowest spheroidal mode of degree 2 (P and S potentials, a 4 x 4 traction determinant),
  found in harmonics 0, 1 and 2: it couples the volume change (lam) into every harmonic;
- six rigid-body modes: two in n = 0 (axial translation, rotation about the axis) and two in
  n = 1 (each a degenerate pair in 3-D).

Every reference is solved twice, on a mesh and on one refined twice in each direction; the
largest relative difference over the modes kept is reported as its convergence.

Usage:
    axisymmetric.py --write presets/fem/tests/data/axisymmetric.json
    axisymmetric.py --check presets/fem/tests/data/axisymmetric.json   (self-tests, then
        recompute the references and compare with the file within 1e-6)
"""

import argparse
import json
import os
import sys

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.optimize import brentq
from scipy.special import spherical_jn, spherical_yn

ORDER = 4  # element order P


def gll_nodes(p):
    """Gauss-Lobatto-Legendre nodes on [-1, 1]."""
    if p == 1:
        return np.array([-1.0, 1.0])
    inner = np.polynomial.legendre.Legendre.basis(p).deriv().roots()
    return np.concatenate(([-1.0], np.sort(inner.real), [1.0]))


def lagrange_1d(nodes, x):
    """Values and derivatives of the Lagrange polynomials on `nodes` at points `x`."""
    m = len(nodes)
    val = np.ones((len(x), m))
    der = np.zeros((len(x), m))
    for i in range(m):
        for j in range(m):
            if j == i:
                continue
            val[:, i] *= (x - nodes[j]) / (nodes[i] - nodes[j])
        for k in range(m):
            if k == i:
                continue
            term = np.full(len(x), 1.0 / (nodes[i] - nodes[k]))
            for j in range(m):
                if j in (i, k):
                    continue
                term *= (x - nodes[j]) / (nodes[i] - nodes[j])
            der[:, i] += term
    return val, der


class Section:
    """A structured meridian section: parameters (s, t) on [s0, s1] x [t0, t1], mapped by
    `geom(s, t) -> (r, z, dr/ds, dr/dt, dz/ds, dz/dt)`."""

    def __init__(self, s_range, t_range, ns, nt, geom):
        self.s_range, self.t_range, self.ns, self.nt, self.geom = s_range, t_range, ns, nt, geom


def disc(radius, thickness, ns, nt):
    def geom(s, t):
        one, zero = np.ones_like(s), np.zeros_like(s)
        return s, t, one, zero, zero, one

    return Section((0.0, radius), (0.0, thickness), ns, nt, geom)


def spherical(radius, wall, phi_max, ns, nt, pole_z):
    """The shell between the spheres of radii radius - wall and radius about (0, pole_z +
    radius), from the downward pole to the polar angle phi_max: parameters phi (s) and rho
    (t), r = rho sin phi, z = pole_z + radius - rho cos phi."""

    def geom(s, t):
        return (t * np.sin(s), pole_z + radius - t * np.cos(s), t * np.cos(s), np.sin(s), t * np.sin(s), -np.cos(s))

    return Section((0.0, phi_max), (radius - wall, radius), ns, nt, geom)


def assemble(section, material, n):
    """Stiffness and mass matrices of harmonic n (the common angular factor dropped)."""
    young, density, nu = material
    lam = young * nu / ((1 + nu) * (1 - 2 * nu))
    mu = young / (2 * (1 + nu))
    p = ORDER
    nodes = gll_nodes(p)
    gx, gw = np.polynomial.legendre.leggauss(p + 3)
    val, der = lagrange_1d(nodes, gx)
    # 2-D tensor basis at the quadrature points: index [q, a], q = (qi, qj), a = (ai, aj).
    n2 = np.einsum("ia,jb->ijab", val, val).reshape(len(gx) ** 2, (p + 1) ** 2)
    dxi = np.einsum("ia,jb->ijab", der, val).reshape(len(gx) ** 2, (p + 1) ** 2)
    deta = np.einsum("ia,jb->ijab", val, der).reshape(len(gx) ** 2, (p + 1) ** 2)
    w2 = np.outer(gw, gw).reshape(-1)
    xi = np.repeat(gx, len(gx))
    eta = np.tile(gx, len(gx))

    ns, nt = section.ns, section.nt
    s_edges = np.linspace(*section.s_range, ns + 1)
    t_edges = np.linspace(*section.t_range, nt + 1)
    cols = nt * p + 1  # nodes along t
    node_count = (ns * p + 1) * cols
    d = np.diag([lam + 2 * mu] * 3 + [mu] * 3)
    d[:3, :3] += lam - np.diag([lam] * 3)

    rows_k, cols_k, vals_k, vals_m = [], [], [], []
    for a in range(ns):
        ds = s_edges[a + 1] - s_edges[a]
        s = s_edges[a] + (xi + 1) * ds / 2
        for b in range(nt):
            dt = t_edges[b + 1] - t_edges[b]
            t = t_edges[b] + (eta + 1) * dt / 2
            r, _z, r_s, r_t, z_s, z_t = section.geom(s, t)
            jac = r_s * z_t - r_t * z_s
            # d/dr, d/dz from d/ds, d/dt (inverse of the 2x2 map).
            dn_ds = dxi * (2 / ds)
            dn_dt = deta * (2 / dt)
            dn_dr = (z_t[:, None] * dn_ds - z_s[:, None] * dn_dt) / jac[:, None]
            dn_dz = (-r_t[:, None] * dn_ds + r_s[:, None] * dn_dt) / jac[:, None]
            weight = w2 * r * np.abs(jac) * ds * dt / 4
            nr = n2 / r[:, None]
            q, m = n2.shape
            bmat = np.zeros((q, 6, 3 * m))
            bmat[:, 0, 0::3] = dn_dr  # e_rr = U_r
            bmat[:, 1, 0::3] = nr  # e_tt = (U + n V) / r
            bmat[:, 1, 1::3] = n * nr
            bmat[:, 2, 2::3] = dn_dz  # e_zz = W_z
            bmat[:, 3, 0::3] = dn_dz  # g_rz = U_z + W_r
            bmat[:, 3, 2::3] = dn_dr
            bmat[:, 4, 0::3] = -n * nr  # g_rt = -n U / r + V_r - V / r
            bmat[:, 4, 1::3] = dn_dr - nr
            bmat[:, 5, 1::3] = dn_dz  # g_tz = V_z - n W / r
            bmat[:, 5, 2::3] = -n * nr
            db = np.einsum("ij,qjb->qib", d, bmat) * weight[:, None, None]
            ke = bmat.reshape(6 * q, 3 * m).T @ db.reshape(6 * q, 3 * m)
            me1 = density * (n2.T @ (n2 * weight[:, None]))
            me = np.kron(me1, np.eye(3))
            ids = np.array([(a * p + i) * cols + (b * p + j) for i in range(p + 1) for j in range(p + 1)])
            dofs = (3 * ids[:, None] + np.arange(3)[None, :]).reshape(-1)
            rows_k.append(np.repeat(dofs, len(dofs)))
            cols_k.append(np.tile(dofs, len(dofs)))
            vals_k.append(ke.reshape(-1))
            vals_m.append(me.reshape(-1))
    rk, ck = np.concatenate(rows_k), np.concatenate(cols_k)
    size = 3 * node_count
    k = sp.coo_matrix((np.concatenate(vals_k), (rk, ck)), shape=(size, size)).tocsr()
    mm = sp.coo_matrix((np.concatenate(vals_m), (rk, ck)), shape=(size, size)).tocsr()
    return k, mm, node_count, cols


def node_positions(span, elements):
    """Positions of the nodes along one direction: each element's Gauss-Lobatto nodes."""
    edges = np.linspace(*span, elements + 1)
    local = (gll_nodes(ORDER) + 1) / 2
    pos = [edges[0]]
    for a in range(elements):
        pos.extend(edges[a] + local[1:] * (edges[a + 1] - edges[a]))
    return np.array(pos)


def axis_map(section, n, node_count, cols):
    """The map T from free DOFs to all DOFs that imposes single-valued motion on the axis
    (r = 0): n = 0: U = V = 0; n = 1: W = 0 and V = -U; n >= 2: U = V = W = 0."""
    s_nodes = node_positions(section.s_range, section.ns)
    t_nodes = node_positions(section.t_range, section.nt)
    rows, cols_t, vals = [], [], []
    free = 0
    for i, s in enumerate(s_nodes):
        for j, t in enumerate(t_nodes):
            node = i * cols + j
            r = section.geom(np.array([s]), np.array([t]))[0][0]
            on_axis = abs(r) < 1e-12 * max(abs(section.t_range[1]), abs(section.s_range[1]))
            base = 3 * node
            if not on_axis:
                for c in range(3):
                    rows.append(base + c), cols_t.append(free), vals.append(1.0)
                    free += 1
            elif n == 0:
                rows.append(base + 2), cols_t.append(free), vals.append(1.0)
                free += 1
            elif n == 1:
                rows.append(base), cols_t.append(free), vals.append(1.0)
                rows.append(base + 1), cols_t.append(free), vals.append(-1.0)
                free += 1
    return sp.coo_matrix((vals, (rows, cols_t)), shape=(3 * node_count, free)).tocsc()


def harmonic(section, material, n, count):
    """The lowest `count` eigenvalues omega^2 of harmonic n (rigid modes included)."""
    k, m, node_count, cols = assemble(section, material, n)
    t = axis_map(section, n, node_count, cols)
    k = (t.T @ k @ t).tocsc()
    m = (t.T @ m @ t).tocsc()
    k = (k + k.T) / 2
    m = (m + m.T) / 2
    # A fixed start vector and a wider Lanczos basis: ARPACK's own random start left a
    # degenerate pair converged only to 1e-8 in about one run in ten (seen in CI).
    v0 = np.random.default_rng(12345).standard_normal(k.shape[0])
    ncv = min(k.shape[0], max(2 * count + 1, 100))
    w2 = spla.eigsh(k, k=count, M=m, sigma=-1.0, which="LM", v0=v0, ncv=ncv, tol=1e-15, return_eigenvectors=False)
    return np.sort(w2)


RIGID = {0: 2, 1: 2}


def spectrum(make, material, modes, refine=1):
    """The lowest `modes` elastic frequencies (Hz) of the 3-D solid, with multiplicity (n >= 1
    modes twice), each with its harmonic n."""
    section = make(refine)
    found = []
    n = 0
    while True:
        rigid = RIGID.get(n, 0)
        w2 = harmonic(section, material, n, modes + rigid)
        if rigid:
            scale = max(abs(w2[rigid]), 1.0)
            if np.any(np.abs(w2[:rigid]) > 1e-6 * scale):
                raise RuntimeError(f"harmonic {n}: expected {rigid} rigid modes, found {w2[: rigid + 1]}")
        freqs = np.sqrt(np.maximum(w2[rigid:], 0.0)) / (2 * np.pi)
        lowest_needed = sorted(f for f, _ in found)[modes - 1] if len(found) >= modes else np.inf
        if freqs[0] > lowest_needed:
            break
        for f in freqs:
            found.extend([(f, n)] * (1 if n == 0 else 2))
        n += 1
        if n > 60:
            raise RuntimeError("no convergence in the harmonics")
    found.sort()
    return found[:modes]


def converged(make, material, modes):
    """The spectrum on the finer of two meshes, and its largest relative change from the
    coarser one."""
    coarse = spectrum(make, material, modes, 1)
    fine = spectrum(make, material, modes, 2)
    change = max(abs(a[0] - b[0]) / b[0] for a, b in zip(coarse, fine))
    return fine, change


# -- self-tests against closed forms -------------------------------------------------------


def shell_roots(det, count, x_max):
    """The first `count` roots of det on (0.05, x_max]: sign changes on a 20,000-point grid,
    each refined by Brent's method. The grid is evaluated as it is scanned (the roots wanted
    lie in its first quarter; evaluating all of it took two minutes of CI)."""
    xs = np.linspace(0.05, x_max, 20000)
    vals = [det(xs[0])]
    roots = []
    for i in range(len(xs) - 1):
        vals.append(det(xs[i + 1]))
        if np.sign(vals[i]) != np.sign(vals[i + 1]) and np.isfinite(vals[i]) and np.isfinite(vals[i + 1]):
            root = brentq(det, xs[i], xs[i + 1], xtol=1e-14)
            if abs(det(root)) < 1e-6 * (abs(vals[i]) + abs(vals[i + 1])) + 1e-300:
                roots.append(root)
        if len(roots) == count:
            break
    return roots


def self_test():
    material = (70e9, 2500.0, 0.22)
    young, density, nu = material
    lam = young * nu / ((1 + nu) * (1 - 2 * nu))
    mu = young / (2 * (1 + nu))
    cs, cp = np.sqrt(mu / density), np.sqrt((lam + 2 * mu) / density)
    a_in, b_out = 0.06, 0.08

    def section(refine):
        return spherical(b_out, b_out - a_in, np.pi, 24 * refine, 2 * refine, 0.0)

    ok = True

    def torsional(l):
        def f(z, x):
            return (l - 1) * z(l, x) - x * z(l + 1, x)

        def det(k):
            return f(spherical_jn, k * a_in) * f(spherical_yn, k * b_out) - f(spherical_jn, k * b_out) * f(
                spherical_yn, k * a_in
            )

        return shell_roots(det, 1, 400.0)[0] * cs / (2 * np.pi)

    def breathing():
        def g(z, k, r):
            return (lam + 2 * mu) * k * z(0, k * r) - 4 * mu * z(1, k * r) / r

        def det(k):
            return g(spherical_jn, k, a_in) * g(spherical_yn, k, b_out) - g(spherical_jn, k, b_out) * g(
                spherical_yn, k, a_in
            )

        return shell_roots(det, 1, 400.0)[0] * cp / (2 * np.pi)

    def spheroidal(l):
        """Lowest spheroidal mode of degree l: u = U(r) P_l e_r + V(r) dP_l/dtheta e_theta from
        a P potential z_l(k_p r) P_l (u = grad) and an S potential z_l(k_s r) P_l (u = curl curl
        (r psi)), z = j, y; traction-free sigma_rr = sigma_rtheta = 0 at both radii."""
        big_l = l * (l + 1)

        def z_and_derivs(z, x):
            f, d = z(l, x), z(l, x, derivative=True)
            # The spherical Bessel equation: f'' = -(2/x) f' - (1 - l(l+1)/x^2) f.
            return f, d, -2 / x * d - (1 - big_l / x**2) * f

        def tractions(z, k, r, shear):
            f, d, dd = z_and_derivs(z, k * r)
            if not shear:
                u, du = k * d, k * k * dd
                v, dv = f / r, k * d / r - f / r**2
                div = -k * k * f
            else:
                u, du = big_l * f / r, big_l * (k * d / r - f / r**2)
                v, dv = f / r + k * d, k * d / r - f / r**2 + k * k * dd
                div = 0.0
            return lam * div + 2 * mu * du, mu * (u / r + dv - v / r)

        def det(w):
            cols = []
            for z, k, shear in ((spherical_jn, w / cp, False), (spherical_yn, w / cp, False), (spherical_jn, w / cs, True), (spherical_yn, w / cs, True)):
                cols.append([*tractions(z, k, a_in, shear), *tractions(z, k, b_out, shear)])
            m = np.array(cols).T
            return np.linalg.det(m / np.abs(m).max(axis=0))

        return shell_roots(det, 1, 2 * np.pi * 40000.0)[0] / (2 * np.pi)

    sec = section(1)
    w2 = {n: harmonic(sec, material, n, 40) for n in range(4)}
    for n, rigid in ((0, 2), (1, 2), (2, 0), (3, 0)):
        scale = abs(w2[n][rigid])
        zeros = int(np.sum(np.abs(w2[n]) < 1e-6 * scale))
        good = zeros == rigid
        ok &= good
        print(f"  harmonic {n}: {zeros} rigid modes (expected {rigid}) {'ok' if good else 'FAIL'}")
    freqs = {n: np.sqrt(np.maximum(w2[n], 0)) / (2 * np.pi) for n in w2}

    def check(name, exact, harmonics):
        nonlocal ok
        for n in harmonics:
            f = freqs[n][np.argmin(np.abs(freqs[n] - exact))]
            err = abs(f - exact) / exact
            good = err < 1e-8
            ok &= good
            print(f"  {name}, harmonic {n}: {f:.6f} Hz vs exact {exact:.6f} Hz, {err:.1e} {'ok' if good else 'FAIL'}")

    check("torsional l=2", torsional(2), (0, 1, 2))
    check("torsional l=3", torsional(3), (0, 1, 2, 3))
    check("breathing l=0", breathing(), (0,))
    check("spheroidal l=2", spheroidal(2), (0, 1, 2))
    return ok


# -- the references ------------------------------------------------------------------------

ALUMINIUM = (69e9, 2700.0, 0.33)
GLASS = (70e9, 2500.0, 0.22)
MODES = 24


def cases():
    # The disc and bowl (#14): aluminium disc R 0.1 m, 3 mm; glass hemispherical
    # bowl, outer radius 0.08 m, wall 4 mm, pole at z = 0, rim in the plane of the centre.
    return [
        (
            "disc",
            {"shape": "circular-plate", "dims": [0.1, 0.003], "material": "aluminium"},
            lambda k: disc(0.1, 0.003, 50 * k, 2 * k),
            ALUMINIUM,
        ),
        (
            "bowl",
            {"shape": "bowl", "dims": [0.08, 0.004], "material": "glass"},
            lambda k: spherical(0.08, 0.004, np.pi / 2, 40 * k, 2 * k, 0.0),
            GLASS,
        ),
    ]


def references():
    out = {}
    for name, meta, make, material in cases():
        modes, change = converged(make, material, MODES)
        young, density, nu = material
        out[name] = {
            **meta,
            "young_pa": young,
            "density_kg_m3": density,
            "poisson": nu,
            "element_order": ORDER,
            "convergence": change,
            "frequencies_hz": [round(f, 6) for f, _ in modes],
            "harmonics": [n for _, n in modes],
        }
        print(f"{name}: {len(modes)} modes, {modes[0][0]:.3f} .. {modes[-1][0]:.3f} Hz, mesh change {change:.1e}")
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--write", metavar="JSON")
    parser.add_argument("--check", metavar="JSON")
    parser.add_argument("--self-test", action="store_true")
    args = parser.parse_args()
    if args.self_test or args.check:
        print("self-test against closed forms:")
        if not self_test():
            print("axisymmetric.py: self-test failed", file=sys.stderr)
            return 1
    if args.write or args.check:
        refs = references()
        for r in refs.values():
            if r["convergence"] > 1e-6:
                print(f"axisymmetric.py: a reference changed by {r['convergence']:.1e} on refinement", file=sys.stderr)
                return 1
        if args.write:
            with open(args.write + ".tmp", "w") as f:
                json.dump(refs, f, indent=1)
                f.write("\n")
            os.replace(args.write + ".tmp", args.write)
        else:
            with open(args.check) as f:
                stored = json.load(f)
            for name, r in refs.items():
                got, want = r["frequencies_hz"], stored[name]["frequencies_hz"]
                worst = max(abs(a - b) / b for a, b in zip(got, want))
                if len(got) != len(want) or worst > 1e-6:
                    print(f"axisymmetric.py: {name} differs from {args.check} by {worst:.1e}", file=sys.stderr)
                    return 1
            print(f"{args.check}: the references reproduce within 1e-6")
    return 0


if __name__ == "__main__":
    sys.exit(main())
