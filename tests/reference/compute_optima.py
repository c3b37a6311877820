#!/usr/bin/python3
"""Reference optima of the minimal-geometry-change problem (Eq. 5 of Gauge,
Coros, Mani, Thomaszewski, "Interactive Design of Modular Tensegrity
Characters", SCA 2014) for the conformance suite, computed independently of
the project's C++ code: plain numpy, dense matrices, Newton's method on the
KKT system with an active set for the sign bounds. One file past 500 lines:
it is standalone on purpose (numpy only, no code shared with the project).

    min_{x, sigma}  |x - x0|^2            (free nodes; fixed nodes never move)
    s.t.  f_i(x, sigma) = sum_e sigma_e (x_j - x_i) / |x_j - x_i| + m_i g = 0
                                           for every free node i
          sum of cable forces of a part = (cables of the part) * F0
          cable sigma >= margin, strut sigma <= -margin, margin = 1e-3 F0

per connected part: F0 = W, the total gravity load on the part's free nodes
(own masses plus half of every touching element's mass), when positive, else
1 N (the project's force-scale convention, docs/THEORY-force-scale.md). Parts
are joined by elements between free nodes; an element with one fixed end
belongs to its free end's part, and elements between two fixed nodes belong
to no part (no equilibrium condition; they are given +-F0 of the whole scene
with their sign, as the scene driver gives them).

A part that already stands (Eq. 4 at the scene geometry: sign-bounded forces
of any level balance it to the relative residual 1e-8 of docs/FORMATS.md) is the
answer unchanged, geometry change 0, as the scene driver returns it; Eq. 5 is
solved for the other parts. For such a scene the Eq. 5 optimum of all parts
is stored too (what a backend must reach without the driver's shortcut).

Usage (from the repository root):
    /usr/bin/python3 tests/reference/compute_optima.py tests/reference/scenes tests/reference/optima.json
"""
import json
import os
import subprocess
import sys

import numpy as np

MARGIN_FRACTION = 1e-3
KKT_TOLERANCE = 1e-12      # infinity norm of the scaled KKT residual
MAX_NEWTON_STEPS = 200
INERTIA_SHIFT = 1e-3       # smallest curvature of a shifted Newton model
EQUILIBRIUM_TOLERANCE = 1e-8  # docs/FORMATS.md's relative residual for `converged`


def load_scene(path):
    with open(path) as f:
        j = json.load(f)
    x = np.array([n["x"] for n in j["nodes"]], dtype=float)
    fixed = np.array([bool(n.get("fixed", False)) for n in j["nodes"]])
    mass = np.array([float(n.get("mass", 0.0)) for n in j["nodes"]])
    elements = []
    for e in j["elements"]:
        a, b = e["nodes"]
        elements.append((int(a), int(b), e["kind"]))
        m = float(e.get("mass", 0.0))
        mass[a] += 0.5 * m
        mass[b] += 0.5 * m
    g = np.array(j.get("gravity", [0.0, 0.0, 0.0]), dtype=float)
    return {"name": j.get("name", os.path.basename(path)), "x0": x, "fixed": fixed,
            "mass": mass, "elements": elements, "gravity": g}


def connected_parts(n, elements, fixed):
    """Parts joined by elements between free nodes; a fixed node joins nothing
    (it is a constant of every part that touches it)."""
    parent = list(range(n))

    def root(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for a, b, _ in elements:
        if not fixed[a] and not fixed[b]:
            parent[root(a)] = root(b)
    roots = sorted({root(i) for i in range(n)})
    return [root(i) for i in range(n)], roots


def element_part(node_part, fixed, a, b):
    """The part of an element is the part of its free end."""
    return node_part[b] if fixed[a] else node_part[a]


class Problem:
    def __init__(self, scene):
        self.s = scene
        n = len(scene["x0"])
        self.free = [i for i in range(n) if not scene["fixed"][i]]
        self.slot = {i: k for k, i in enumerate(self.free)}  # free node -> block index
        self.nx = 3 * len(self.free)
        self.m = len(scene["elements"])
        self.loads = scene["mass"][:, None] * scene["gravity"][None, :]
        fixed = scene["fixed"]
        node_part, roots = connected_parts(n, scene["elements"], fixed)
        self.element_part = [element_part(node_part, fixed, a, b) for a, b, _ in scene["elements"]]
        self.node_part = node_part
        f0 = {}
        for r in roots:
            weight = sum(np.linalg.norm(self.loads[i]) for i in self.free if node_part[i] == r)
            f0[r] = weight if weight > 0.0 else 1.0
        self.part_f0 = f0
        self.parts = []  # (F0, cable indices) per part with cables
        for r in roots:
            cables = [e for e, (a, b, k) in enumerate(scene["elements"])
                      if k == "cable" and self.element_part[e] == r]
            if cables:
                self.parts.append((f0[r], cables))
        self.lower = np.full(self.m, -np.inf)
        self.upper = np.full(self.m, np.inf)
        for e, (a, b, k) in enumerate(scene["elements"]):
            if k == "cable":
                self.lower[e] = MARGIN_FRACTION * f0[self.element_part[e]]
            else:
                self.upper[e] = -MARGIN_FRACTION * f0[self.element_part[e]]
        self.nc = self.nx + len(self.parts)

    def positions(self, xf):
        x = self.s["x0"].copy()
        for k, i in enumerate(self.free):
            x[i] = xf[3 * k:3 * k + 3]
        return x

    def constraints(self, xf, sigma):
        """c(z) and its Jacobian [dc/dx, dc/dsigma]."""
        x = self.positions(xf)
        c = np.zeros(self.nc)
        jx = np.zeros((self.nc, self.nx))
        js = np.zeros((self.nc, self.m))
        for i in self.free:
            c[3 * self.slot[i]:3 * self.slot[i] + 3] += self.loads[i]
        for e, (a, b, _) in enumerate(self.s["elements"]):
            d = x[b] - x[a]
            l = np.linalg.norm(d)
            u = d / l
            p = (np.eye(3) - np.outer(u, u)) / l
            for node, sign in ((a, 1.0), (b, -1.0)):
                if node not in self.slot:
                    continue
                r = 3 * self.slot[node]
                c[r:r + 3] += sign * sigma[e] * u
                js[r:r + 3, e] = sign * u
                # d(sign * sigma * u)/dx_b = sign * sigma * P/l, /dx_a = the negative.
                for other, s2 in ((b, 1.0), (a, -1.0)):
                    if other in self.slot:
                        q = 3 * self.slot[other]
                        jx[r:r + 3, q:q + 3] += sign * s2 * sigma[e] * p
        for k, (f0, cables) in enumerate(self.parts):
            row = self.nx + k
            c[row] = sigma[cables].sum() - len(cables) * f0
            js[row, cables] = 1.0
        return c, jx, js

    def lagrangian_hessian(self, xf, sigma, lam):
        """Second derivatives of |x - x0|^2 + lam . c with respect to (x, sigma)."""
        x = self.positions(xf)
        hxx = 2.0 * np.eye(self.nx)
        hxs = np.zeros((self.nx, self.m))
        lam_node = {i: lam[3 * k:3 * k + 3] for k, i in enumerate(self.free)}
        zero = np.zeros(3)
        for e, (a, b, _) in enumerate(self.s["elements"]):
            w = lam_node.get(a, zero) - lam_node.get(b, zero)
            d = x[b] - x[a]
            l = np.linalg.norm(d)
            u = d / l
            wu = w @ u
            # h(d) = w . d / |d|: gradient P w / l, Hessian below (d = x_b - x_a).
            grad = (w - wu * u) / l
            hess = (-(np.outer(w, u) + np.outer(u, w)) - wu * np.eye(3) + 3.0 * wu * np.outer(u, u)) / l ** 2
            for n1, s1 in ((b, 1.0), (a, -1.0)):
                if n1 not in self.slot:
                    continue
                r = 3 * self.slot[n1]
                hxs[r:r + 3, e] += s1 * grad
                for n2, s2 in ((b, 1.0), (a, -1.0)):
                    if n2 in self.slot:
                        q = 3 * self.slot[n2]
                        hxx[r:r + 3, q:q + 3] += s1 * s2 * sigma[e] * hess
        return hxx, hxs


def initial_forces(prob, xf):
    """Least-squares forces at the scene geometry, moved inside the sign bounds."""
    c, jx, js = prob.constraints(xf, np.zeros(prob.m))
    sigma = np.linalg.lstsq(js, -c, rcond=None)[0]
    cable = np.isfinite(prob.lower)
    return np.where(cable, np.maximum(sigma, 2.0 * prob.lower), np.minimum(sigma, 2.0 * prob.upper))


def restore_feasibility(prob, xf, sigma):
    """Minimum-norm Gauss-Newton steps on the constraints: a feasible point
    near the scene geometry, inside the sign bounds, to start Newton from."""
    for _ in range(100):
        c, jx, js = prob.constraints(xf, sigma)
        if np.abs(c).max() <= 1e-13 * max(1.0, np.abs(prob.loads).max()):
            break
        step = -np.linalg.lstsq(np.hstack([jx, js]), c, rcond=None)[0]
        dx, ds = step[:prob.nx], step[prob.nx:]
        alpha = 1.0
        for e in range(prob.m):  # stay strictly inside the bounds
            if sigma[e] + ds[e] < prob.lower[e]:
                alpha = min(alpha, 0.9 * (prob.lower[e] - sigma[e]) / ds[e])
            if sigma[e] + ds[e] > prob.upper[e]:
                alpha = min(alpha, 0.9 * (prob.upper[e] - sigma[e]) / ds[e])
        xf, sigma = xf + alpha * dx, sigma + alpha * ds
    return xf, sigma


def feasible_descent(prob, xf, sigma, x0f):
    """Globalisation: reduced Newton steps on the constraints' tangent space
    (Hessian of the Lagrangian shifted to be positive definite there), each
    followed by restore_feasibility and accepted when |x - x0|^2 decreases.
    Ends near a local optimum, where the Newton-KKT iteration takes over."""
    for _ in range(500):
        c, jx, js = prob.constraints(xf, sigma)
        jac = np.hstack([jx, js])
        grad = np.concatenate([2.0 * (xf - x0f), np.zeros(prob.m)])
        lam = np.linalg.lstsq(jac.T, -grad, rcond=None)[0]
        _, sv, vt = np.linalg.svd(jac)
        rank = int((sv > 1e-10 * sv[0]).sum())
        null = vt[rank:].T
        reduced_grad = null.T @ grad
        if np.abs(reduced_grad).max() <= 1e-6 * max(1.0, np.abs(grad).max()):
            break
        hxx, hxs = prob.lagrangian_hessian(xf, sigma, lam)
        h = np.block([[hxx, hxs], [hxs.T, np.zeros((prob.m, prob.m))]])
        hr = null.T @ h @ null
        low = np.linalg.eigvalsh(hr).min()
        if low < 1e-3:
            hr += (1e-3 - low) * np.eye(len(hr))
        p = -null @ np.linalg.solve(hr, reduced_grad)
        f_now = (xf - x0f) @ (xf - x0f)
        alpha = 1.0
        while alpha > 1e-10:
            xn, sn = restore_feasibility(prob, xf + alpha * p[:prob.nx], sigma + alpha * p[prob.nx:])
            if np.all(sn >= prob.lower) and np.all(sn <= prob.upper) and (xn - x0f) @ (xn - x0f) < f_now:
                break
            alpha *= 0.5
        else:
            break
        xf, sigma = xn, sn
    return xf, sigma


def kkt(prob, xf, sigma, lam, active):
    """KKT residual (gradient of the Lagrangian on inactive variables, constraints)."""
    x0f = np.concatenate([prob.s["x0"][i] for i in prob.free])
    c, jx, js = prob.constraints(xf, sigma)
    gx = 2.0 * (xf - x0f) + jx.T @ lam
    gs = js.T @ lam
    return c, jx, js, gx, gs


def solve(prob):
    xf = np.concatenate([prob.s["x0"][i] for i in prob.free])
    x0f = xf.copy()
    sigma = initial_forces(prob, xf)
    active = set()
    xf, sigma = restore_feasibility(prob, xf, sigma)
    xf, sigma = feasible_descent(prob, xf, sigma, x0f)
    # Least-squares multipliers at the feasible start.
    c, jx, js, gx, gs = kkt(prob, xf, sigma, np.zeros(prob.nc), active)
    lam = np.linalg.lstsq(np.hstack([jx, js]).T, -np.concatenate([gx, gs]), rcond=None)[0]
    scale = max(1.0, np.abs(prob.loads).max())

    def residual_norm(xf, sigma, lam, active):
        c, _, _, gx, gs = kkt(prob, xf, sigma, lam, active)
        inactive = [e for e in range(prob.m) if e not in active]
        return np.sqrt(c @ c + gx @ gx + gs[inactive] @ gs[inactive])

    steps = 0
    while steps < MAX_NEWTON_STEPS:
        steps += 1
        c, jx, js, gx, gs = kkt(prob, xf, sigma, lam, active)
        inactive = [e for e in range(prob.m) if e not in active]
        res = max(np.abs(c).max(), np.abs(gx).max(),
                  np.abs(gs[inactive]).max() if inactive else 0.0) / scale
        if res <= KKT_TOLERANCE:
            # Release an active bound whose multiplier has the wrong sign.
            # dL/dsigma_e = gs_e must be >= 0 at a lower bound, <= 0 at an upper one.
            wrong = [e for e in active
                     if (np.isfinite(prob.lower[e]) and gs[e] < -1e-10) or
                     (np.isfinite(prob.upper[e]) and gs[e] > 1e-10)]
            if not wrong:
                break
            active.discard(wrong[0])
            continue
        hxx, hxs = prob.lagrangian_hessian(xf, sigma, lam)
        nv = prob.nx + len(inactive)
        k = np.zeros((nv + prob.nc, nv + prob.nc))
        k[:prob.nx, :prob.nx] = hxx
        k[:prob.nx, prob.nx:nv] = hxs[:, inactive]
        k[prob.nx:nv, :prob.nx] = hxs[:, inactive].T
        jac = np.hstack([jx, js[:, inactive]])
        # Inertia correction: where the Lagrangian's Hessian is indefinite on the
        # constraints' null space (after releasing a bound, say), shift it to be
        # positive definite there, so that the step descends instead of heading
        # for a saddle point.
        _, sv, vt = np.linalg.svd(jac)
        null = vt[int((sv > 1e-10 * sv[0]).sum()):].T
        if null.shape[1]:
            low = np.linalg.eigvalsh(null.T @ k[:nv, :nv] @ null).min()
            if low <= 0.0:
                k[:nv, :nv] += (INERTIA_SHIFT - low) * np.eye(nv)
        k[:nv, nv:] = jac.T
        k[nv:, :nv] = jac
        rhs = -np.concatenate([gx, gs[inactive], c])
        step = np.linalg.lstsq(k, rhs, rcond=None)[0]
        dx, ds, dl = step[:prob.nx], step[prob.nx:nv], step[nv:]
        # Longest step that keeps the inactive forces inside their bounds.
        alpha, blocking = 1.0, None
        for idx, e in enumerate(inactive):
            s_new = sigma[e] + ds[idx]
            if s_new < prob.lower[e]:
                a = (prob.lower[e] - sigma[e]) / ds[idx]
            elif s_new > prob.upper[e]:
                a = (prob.upper[e] - sigma[e]) / ds[idx]
            else:
                continue
            if a < alpha:
                alpha, blocking = a, e
        # Backtracking on the KKT residual norm (Newton is a descent direction for it).
        r0 = residual_norm(xf, sigma, lam, active)
        while True:
            xn = xf + alpha * dx
            sn = sigma.copy()
            sn[inactive] += alpha * ds
            ln = lam + alpha * dl
            if blocking is not None:
                sn[blocking] = prob.lower[blocking] if np.isfinite(prob.lower[blocking]) else prob.upper[blocking]
            if residual_norm(xn, sn, ln, active | ({blocking} if blocking is not None else set())) < r0 or alpha < 1e-8:
                break
            alpha *= 0.5
            blocking = None
        xf, sigma, lam = xn, sn, ln
        if blocking is not None:
            active.add(blocking)
    c, jx, js, gx, gs = kkt(prob, xf, sigma, lam, active)
    inactive = [e for e in range(prob.m) if e not in active]
    res = max(np.abs(c).max(), np.abs(gx).max(), np.abs(gs[inactive]).max() if inactive else 0.0) / scale
    # A bound held with a multiplier of the wrong sign is no optimum (the
    # active-set loop can cycle on one and end at the step limit).
    wrong_multipliers = [e for e in active
                         if (np.isfinite(prob.lower[e]) and gs[e] < -1e-10) or
                         (np.isfinite(prob.upper[e]) and gs[e] > 1e-10)]
    # Second-order check: the Lagrangian's Hessian on the constraints' null space.
    hxx, hxs = prob.lagrangian_hessian(xf, sigma, lam)
    nv = prob.nx + len(inactive)
    h = np.zeros((nv, nv))
    h[:prob.nx, :prob.nx] = hxx
    h[:prob.nx, prob.nx:] = hxs[:, inactive]
    h[prob.nx:, :prob.nx] = hxs[:, inactive].T
    jac = np.hstack([jx, js[:, inactive]])
    _, sv, vt = np.linalg.svd(jac)
    rank = int((sv > 1e-10 * sv[0]).sum())
    null = vt[rank:].T
    reduced_min = float(np.linalg.eigvalsh(null.T @ h @ null).min()) if null.shape[1] else float("inf")
    x = prob.positions(xf)
    return {
        "positions": x.tolist(),
        "forces": sigma.tolist(),
        "geometry_change": float(np.linalg.norm(x - prob.s["x0"])),
        "kkt_residual": float(res),
        "newton_steps": steps,
        "active_bounds": sorted(int(e) for e in active),
        "reduced_hessian_min_eigenvalue": reduced_min,
        "equilibrium_residual": float(np.abs(c[:prob.nx]).max()) if prob.nx else 0.0,
        "converged": bool(res <= KKT_TOLERANCE and not wrong_multipliers),
    }


def finite_difference_check(prob, rng):
    """Largest relative error of the analytic derivatives against central differences."""
    xf = np.concatenate([prob.s["x0"][i] for i in prob.free]) + 1e-2 * rng.standard_normal(prob.nx)
    sigma = rng.standard_normal(prob.m)
    lam = rng.standard_normal(prob.nc)
    c, jx, js = prob.constraints(xf, sigma)
    hxx, hxs = prob.lagrangian_hessian(xf, sigma, lam)
    h = 1e-6
    worst = 0.0
    for k in range(prob.nx):
        dxv = np.zeros(prob.nx)
        dxv[k] = h
        cp, jxp, jsp = prob.constraints(xf + dxv, sigma)
        cm, jxm, jsm = prob.constraints(xf - dxv, sigma)
        worst = max(worst, np.abs((cp - cm) / (2 * h) - jx[:, k]).max())
        gp = 2 * (xf + dxv) + jxp.T @ lam
        gm = 2 * (xf - dxv) + jxm.T @ lam
        worst = max(worst, np.abs((gp - gm) / (2 * h) - hxx[:, k]).max())
        worst = max(worst, np.abs((jsp.T @ lam - jsm.T @ lam) / (2 * h) - hxs[k, :]).max())
    return worst


def nonnegative_least_squares(a, b):
    """min |a p - b| over p >= 0 (Lawson and Hanson's active-set method)."""
    n = a.shape[1]
    positive = np.zeros(n, dtype=bool)
    p = np.zeros(n)
    tol = 10.0 * np.finfo(float).eps * np.abs(a).sum(axis=0).max() * max(a.shape)
    for _ in range(3 * n + 10):
        w = a.T @ (b - a @ p)
        candidates = np.where(~positive & (w > tol))[0]
        if len(candidates) == 0:
            break
        positive[candidates[np.argmax(w[candidates])]] = True
        while True:
            z = np.zeros(n)
            z[positive] = np.linalg.lstsq(a[:, positive], b, rcond=None)[0]
            if np.all(z[positive] > 0.0):
                break
            blocking = positive & (z <= 0.0)
            alpha = np.min(p[blocking] / (p[blocking] - z[blocking]))
            p = p + alpha * (z - p)
            positive &= p > tol
            p[~positive] = 0.0
        p = z
    return p


def standing_parts(prob):
    """Eq. 4 at the scene geometry, part by part: the sign-bounded least-squares
    forces (the margins as bounds, no force level) and whether they balance the
    part to the tolerance of docs/FORMATS.md, as the scene driver checks before solving.
    Returns {part root: (stands, relative residual, forces, forces unique)}."""
    xf = np.concatenate([prob.s["x0"][i] for i in prob.free])
    c, _, js = prob.constraints(xf, np.zeros(prob.m))
    result = {}
    for r in sorted(set(prob.element_part)):
        cols = [e for e in range(prob.m) if prob.element_part[e] == r]
        nodes = [i for i in prob.free if prob.node_part[i] == r]
        rows = [3 * prob.slot[i] + k for i in nodes for k in range(3)]
        a = js[np.ix_(rows, cols)]
        load = c[rows]
        sign = np.where(np.isfinite(prob.lower[cols]), 1.0, -1.0)
        start = np.where(sign > 0.0, prob.lower[cols], prob.upper[cols])
        # sigma = start + sign * p with p >= 0 keeps every force beyond its margin.
        p = nonnegative_least_squares(a * sign[None, :], -(load + a @ start))
        sigma = start + sign * p
        net = (a @ sigma + load).reshape(-1, 3)
        weight = max(np.linalg.norm(prob.loads[i]) for i in nodes)
        scale = weight if weight > 0.0 else np.abs(sigma).max()
        relative = float(np.linalg.norm(net, axis=1).max() / scale)
        unique = bool(np.linalg.matrix_rank(a) == len(cols))
        result[r] = (relative <= EQUILIBRIUM_TOLERANCE, relative, dict(zip(cols, sigma)), unique)
    return result


def subscene(scene, elements, fixed):
    """The scene with only the given elements and the given fixed flags."""
    sub = dict(scene)
    sub["elements"] = [scene["elements"][e] for e in elements]
    sub["fixed"] = fixed
    return sub


def reference_optimum(scene, rng):
    """What the scene driver must return: parts that stand (Eq. 4 at the scene
    geometry) unchanged, the Eq. 5 optimum of the others. Elements between two
    fixed nodes are in no part: no equilibrium condition, only a sign; they get
    the scene's F0 with their sign, as the driver gives them."""
    fixed = scene["fixed"]
    elements = scene["elements"]
    attached = [e for e, (a, b, _) in enumerate(elements) if not (fixed[a] and fixed[b])]
    unattached = [e for e in range(len(elements)) if e not in attached]
    whole = Problem(subscene(scene, attached, fixed))
    fd = finite_difference_check(whole, rng)
    parts = standing_parts(whole)
    stand = {r for r, (ok, _, _, _) in parts.items() if ok}
    # Standing parts become constants: their free nodes fixed, their elements out.
    moving_fixed = fixed.copy()
    for i in whole.free:
        if whole.node_part[i] in stand:
            moving_fixed[i] = True
    moving = [attached[k] for k in range(whole.m) if whole.element_part[k] not in stand]
    forces = np.zeros(len(elements))
    if moving:
        result = solve(Problem(subscene(scene, moving, moving_fixed)))
        forces[moving] = result["forces"]
        result["active_bounds"] = [moving[k] for k in result["active_bounds"]]  # scene numbering
    else:
        x = scene["x0"]
        result = {"positions": x.tolist(), "geometry_change": 0.0, "kkt_residual": None,
                  "newton_steps": 0, "active_bounds": [], "reduced_hessian_min_eigenvalue": None,
                  "equilibrium_residual": None, "converged": True}
    for r in stand:
        for k, sigma in parts[r][2].items():
            forces[attached[k]] = sigma
    weight = sum(np.linalg.norm(whole.loads[i]) for i in whole.free)
    f0 = weight if weight > 0.0 else 1.0
    for e in unattached:
        forces[e] = f0 if elements[e][2] == "cable" else -f0
    result["forces"] = forces.tolist()
    if stand:
        # What a backend run without the driver's shortcut must reach: Eq. 5
        # for every part, the standing ones included.
        direct = solve(whole)
        direct_forces = np.zeros(len(elements))
        direct_forces[attached] = direct["forces"]
        for e in unattached:
            direct_forces[e] = f0 if elements[e][2] == "cable" else -f0
        direct["forces"] = direct_forces.tolist()
        direct["active_bounds"] = [attached[k] for k in direct["active_bounds"]]
        result["eq5_without_shortcut"] = direct
    result["derivative_check_max_error"] = fd
    result["stands"] = bool(stand) and not moving
    result["parts_standing"] = len(stand)
    result["parts"] = len(parts)
    result["eq4_relative_residual"] = max(rel for _, rel, _, _ in parts.values())
    result["eq4_forces_unique"] = all(parts[r][3] for r in stand)
    result["unattached_elements"] = unattached
    return result


def main(argv):
    if len(argv) != 3:
        print(__doc__, file=sys.stderr)
        return 2
    scene_dir, out_path = argv[1], argv[2]
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    try:
        commit = subprocess.run(["git", "-C", root, "rev-parse", "HEAD"], capture_output=True,
                                text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        commit = "unknown"
    rng = np.random.default_rng(1)
    # A stream of its own, so that the entries without gravity do not depend on
    # which gravity scenes there are.
    gravity_rng = np.random.default_rng(2)
    scenes = []
    for name in sorted(os.listdir(scene_dir)):
        if not name.endswith(".scene.json"):
            continue
        scene = load_scene(os.path.join(scene_dir, name))
        gravity = bool(np.any(scene["gravity"] != 0.0))
        result = reference_optimum(scene, gravity_rng if gravity else rng)
        fd = result["derivative_check_max_error"]
        print("%-34s |dx| %.12g  KKT %s  steps %d  active %s  min eig %s  fd %.1e  stands %d/%d (Eq. 4 %.1e)" % (
            scene["name"], result["geometry_change"], result["kkt_residual"], result["newton_steps"],
            result["active_bounds"], result["reduced_hessian_min_eigenvalue"], fd,
            result["parts_standing"], result["parts"], result["eq4_relative_residual"]), file=sys.stderr)
        if not result["converged"] or fd > 1e-5:
            print("compute_optima: %s: not converged or wrong derivatives" % name, file=sys.stderr)
            return 1
        if result["reduced_hessian_min_eigenvalue"] is not None and not result["reduced_hessian_min_eigenvalue"] > 0.0:
            print("compute_optima: %s: not a strict local minimum" % name, file=sys.stderr)
            return 1
        if result["parts_standing"] and not result["eq4_forces_unique"]:
            print("compute_optima: %s: a standing part has no unique forces to compare" % name, file=sys.stderr)
            return 1
        result["file"] = name
        result["name"] = scene["name"]
        result["gravity"] = gravity
        keys = ["name", "file", "gravity", "geometry_change", "kkt_residual", "equilibrium_residual",
                "newton_steps", "active_bounds", "reduced_hessian_min_eigenvalue",
                "derivative_check_max_error"]
        if gravity:
            keys += ["stands", "eq4_relative_residual", "unattached_elements"]
        direct = result.get("eq5_without_shortcut")
        if direct is not None:
            print("%-34s without the shortcut: |dx| %.12g  KKT %.2e  steps %d  active %s  min eig %.3g" % (
                scene["name"], direct["geometry_change"], direct["kkt_residual"], direct["newton_steps"],
                direct["active_bounds"], direct["reduced_hessian_min_eigenvalue"]), file=sys.stderr)
            if not direct["converged"] or not direct["reduced_hessian_min_eigenvalue"] > 0.0:
                print("compute_optima: %s: Eq. 5 without the shortcut: no strict local minimum found" % name,
                      file=sys.stderr)
                return 1
            result["eq5_without_shortcut"] = {k: direct[k] for k in (
                "geometry_change", "kkt_residual", "equilibrium_residual", "newton_steps", "active_bounds",
                "reduced_hessian_min_eigenvalue", "positions", "forces")}
            keys.append("eq5_without_shortcut")
        elif result["parts_standing"]:
            print("compute_optima: %s: a part stands without load; the entry format assumes none does" % name,
                  file=sys.stderr)
            return 1
        scenes.append({k: result[k] for k in keys + ["positions", "forces"]})
    out = {
        "format": "tensegrity-reference-optima",
        "version": 1,
        "problem": "Eq. 5: min |x - x0|^2 s.t. equilibrium, sign bounds with margin 1e-3 F0, "
                   "mean cable force per part = F0 (F0 = part's free-node weight W, else 1 N); "
                   "a part that stands (Eq. 4 at x0) is unchanged",
        "method": "Newton on the KKT system with an active set for the sign bounds (numpy, dense)",
        "command": "/usr/bin/python3 tests/reference/compute_optima.py tests/reference/scenes "
                   "tests/reference/optima.json",
        "commit": commit,
        "numpy": np.__version__,
        "scenes": scenes,
    }
    tmp = out_path + ".tmp"
    with open(tmp, "w") as f:
        json.dump(out, f, indent=1)
        f.write("\n")
    os.replace(tmp, out_path)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
