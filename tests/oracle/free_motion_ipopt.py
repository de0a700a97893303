#!/usr/bin/env python3
"""An independent optimiser for arcsim's free motion (issue 30): does IPOPT find a shorter delivery?

For each case (plan, machine, arc ends) this script runs `arcsim simulate --motion free` and takes
from its `--json` result the problem (per layer: angle, window, irradiation time; per transition:
ELST, arc change; the gantry limits J, A, D, V) and arcsim's total, and from its `--csv` timeline
the states (angle, speed, acceleration) used as the starting point. It then solves the free-motion
problem on its own and compares.

Formulation (direct multiple shooting, all in absolute gantry angle, deg and s):

* The delivery is a chain of *stages*: per arc, beam 0, switch 0->1, beam 1, ..., beam n-1; between
  two arcs an arc change; with free arc ends a run-up before the first beam. Every stage is cut into
  intervals of constant jerk (`BEAM_PIECES` per moving beam, `SWITCH_PIECES` per switch,
  `RUN_UP_PIECES`, `TURN_PIECES` per arc change; one piece of zero jerk for a beam at rest).
* Variables: the state (angle, speed, acceleration) at every node, the jerk j_i and the duration
  h_i >= 0 of every interval. Nodes are joined by exact integration of the constant-jerk
  polynomial (the defects are equality constraints).
* Limits: |j_i| <= J; at every node 0 <= d*speed <= V and -D <= d*accel <= A (d = +1 CW, -1 CC;
  no reversal inside an arc). The acceleration is linear inside an interval, so nodes suffice. The
  speed is quadratic: its Bernstein middle coefficient v_i + a_i*h_i/2 is also held in [0, V]
  (the curve lies in the hull of its Bernstein coefficients), which is sufficient, slightly
  conservative. Inside an arc the angle is then monotone, so a beam's nodes inside its window
  [theta_k - w_k/2, theta_k + w_k/2] keep the whole irradiation inside it.
* Beam k: its intervals last exactly t_k in all. Switch into layer k: at least ELST_k. Arc change:
  rest to rest, either direction (|speed| <= V, |accel| <= min(A, D)), at least its ELST.
* Arc ends `rest`: the first and last layer of every arc are irradiated at rest (speed and accel 0)
  anywhere in their windows. `free` (single-arc plans): a run-up from rest, anywhere, is counted;
  the first and last beams may move; nothing after the last beam-off counts.
* Objective: the total duration (first beam-on, or run-up start, to last beam-off), plus a tiny
  penalty on the jerks (`REG`) that keeps IPOPT's steps well defined.

IPOPT (through CasADi, exact Hessian) starts from arcsim's own timeline: its states at arcsim's
beam edges and jerk changes. The best iterate whose constraints hold to `FEAS` is kept, and IPOPT
is stopped once it has not improved for `STALL_ITERS` iterations (`Watch`). IPOPT's joins still
carry defects of ~1e-10, which re-integration would add up, so every beam is scaled to its
irradiation time and each motion stage between beams is re-aimed at IPOPT's state at its end by
a least-norm Newton correction of its jerks and durations (`repair`). The answer is then checked
without CasADi: the jerks and durations alone are re-integrated from the start state in float64
and every interval is sampled densely against J, A, D, V, no reversal, every window for the whole
of every irradiation, every irradiation time and every ELST, with tolerance `TOL`. Only a verified
solution counts. The case passes when arcsim_total <= oracle_total * (1 + GAP).

Usage: free_motion_ipopt.py --arcsim BIN --repo DIR --out RESULT.json [--jobs N] [--only NAME ...]
Prints a table (case, arc ends, arcsim total, oracle total, gap) and writes it as JSON. Exit status
0 when every case passes, 1 when arcsim is beaten by more than GAP, a case has no verified
solution, or a run failed.

Run by `cargo test -p arcsim --test free_motion_oracle` (crates/cli/tests/free_motion_oracle.rs).
"""

import argparse
import csv
import json
import os
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor, as_completed

# One thread per case (the cases run in parallel, `--jobs`): set before numpy and CasADi load.
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402
import casadi as ca  # noqa: E402

BEAM_PIECES = 3
SWITCH_PIECES = 8
RUN_UP_PIECES = 4
TURN_PIECES = 8
TOL = 1e-6  # verification tolerance (deg, deg/s, deg/s^2, deg/s^3, s)
GAP = 5e-4  # largest allowed relative shortening of arcsim's total
SAMPLES = 40  # sample points inside every interval in the verification
# A tiny penalty on the jerks (s per (deg/s^3)^2): a piece that shrinks to nothing leaves its jerk
# undetermined otherwise, and IPOPT then needs several times the iterations. It moves the total
# by well under 1e-5 s; the total reported is the verified sum of the durations alone.
REG = 1e-6
# IPOPT's time limit per case; the best iterate so far is still verified. The 722-layer head-neck
# needs most of 150 s on an idle 2-core machine: at 150 s a slower machine stopped it before any
# iterate held its constraints (no verified answer), so the limit leaves room for that.
MAX_WALL_S = 300.0
FEAS = 1e-8  # largest constraint violation of an iterate that `Watch` may keep
STALL_REL, STALL_ITERS = 1e-9, 50  # `Watch` stops IPOPT after this many iterations without gain

# (name, plan, machine or None for arcsim's default, arc ends)
CASES = [
    ("atom/prostate", "plans/atom/prostate.json", "scenarios/machine-atom.json", "rest"),
    ("atom/head-and-neck", "plans/atom/head-and-neck.json", "scenarios/machine-atom.json", "rest"),
    ("atom/liver", "plans/atom/liver.json", "scenarios/machine-atom.json", "rest"),
    ("atom/prostate", "plans/atom/prostate.json", "scenarios/machine-atom.json", "free"),
    ("atom/head-and-neck", "plans/atom/head-and-neck.json", "scenarios/machine-atom.json", "free"),
    ("atom/liver", "plans/atom/liver.json", "scenarios/machine-atom.json", "free"),
    ("prostate", "plans/prostate.json", None, "rest"),
    ("lung", "plans/lung.json", None, "rest"),
    ("two-arc", "plans/two-arc.json", None, "rest"),
]

# The 722-layer bundled head-neck, run only when named with --only: about 70 s of arcsim and 250 s
# of IPOPT on 2 cores, more than all the cases above together (crates/cli/tests/free_motion_oracle.rs
# runs it in an ignored test).
LONG_CASES = [
    ("head-neck", "plans/head-neck.json", None, "rest"),
]

# Cases on another machine, run only when named with --only (issue 45: the refinement is far from
# the optimum on lung there; crates/cli/tests/free_motion_oracle.rs runs them in an ignored test).
OTHER_MACHINE_CASES = [
    ("lung-fast", "plans/lung.json", "scenarios/machine-fast.json", "rest"),
    ("prostate-fast", "plans/prostate.json", "scenarios/machine-fast.json", "rest"),
    ("two-arc-fast", "plans/two-arc.json", "scenarios/machine-fast.json", "rest"),
]


# ----------------------------------------------------------------------------------------------
# The problem, from arcsim's result


class Problem:
    """One plan on one machine: layers, transitions, limits, arc directions, arc ends."""

    def __init__(self, result, plan_json, ends):
        lim = result["limits"]
        self.J = lim["max_jerk_deg_per_s3"]
        self.A = lim["max_accel_deg_per_s2"]
        self.D = lim.get("max_decel_deg_per_s2") or self.A
        self.V = lim["max_speed_deg_per_s"]
        self.ends = ends
        layers = result["layers"]
        self.n = len(layers)
        self.arc = [l["arc"] for l in layers]
        self.angle = np.array([l["angle_deg"] for l in layers])
        self.window = np.array([l["window_deg"] for l in layers])
        self.t_irr = np.array([l["irradiation_s"] for l in layers])
        self.lo = self.angle - 0.5 * self.window
        self.hi = self.angle + 0.5 * self.window
        # ELST into layer k (k >= 1) and whether that switch changes arc.
        self.elst = np.zeros(self.n)
        self.turn = np.zeros(self.n, dtype=bool)
        for t in result["transitions"]:
            assert t["to_layer"] == t["from_layer"] + 1
            self.elst[t["to_layer"]] = t["elst_s"]
            self.turn[t["to_layer"]] = t["arc_change"]
        narcs = max(self.arc) + 1
        self.dir = []
        for a in range(narcs):
            d = plan_json["arcs"][a]["direction"] if plan_json else None
            if d in ("CW", "CC"):
                self.dir.append(1.0 if d == "CW" else -1.0)
            else:  # infer from the layers
                ks = [k for k in range(self.n) if self.arc[k] == a]
                self.dir.append(1.0 if self.angle[ks[-1]] >= self.angle[ks[0]] else -1.0)
        if ends == "free" and narcs > 1:
            raise RuntimeError("free arc ends: only single-arc plans are modelled here")
        first = [self.arc[k] != self.arc[k - 1] if k else True for k in range(self.n)]
        last = [self.arc[k] != self.arc[k + 1] if k + 1 < self.n else True for k in range(self.n)]
        self.first, self.last = first, last
        self.rest_beam = [(first[k] or last[k]) and ends == "rest" for k in range(self.n)]

    def stages(self):
        """The chain of stages: (kind, layer, pieces); kind in run_up, beam, switch, turn."""
        out = []
        if self.ends == "free":
            out.append(("run_up", 0, RUN_UP_PIECES))
        for k in range(self.n):
            if k > 0:
                out.append(
                    (
                        "turn" if self.turn[k] else "switch",
                        k,
                        TURN_PIECES if self.turn[k] else SWITCH_PIECES,
                    )
                )
            out.append(("beam", k, 1 if self.rest_beam[k] else BEAM_PIECES))
        return out


# ----------------------------------------------------------------------------------------------
# Exact constant-jerk integration


def step(x, v, a, j, h):
    """State after `h` seconds of constant jerk `j` (works on floats, arrays and CasADi)."""
    return (
        x + v * h + a * h * h / 2 + j * h * h * h / 6,
        v + a * h + j * h * h / 2,
        a + j * h,
    )


# ----------------------------------------------------------------------------------------------
# The starting point: arcsim's timeline


def read_timeline(path):
    with open(path) as f:
        rows = list(csv.reader(f))
    head = rows[0]
    cols = {
        name: head.index(name)
        for name in ("t_s", "angle_deg", "speed_deg_per_s", "accel_deg_per_s2", "jerk_deg_per_s3")
    }
    data = np.array([[float(r[cols[c]]) for c in cols] for r in rows[1:] if r])
    return data  # t, angle, speed, accel, jerk


def state_at(tl, t):
    """arcsim's state at time `t`, integrated from the last sample at or before it."""
    i = int(np.searchsorted(tl[:, 0], t, side="right")) - 1
    i = min(max(i, 0), len(tl) - 1)
    t0, x, v, a, j = tl[i]
    return step(x, v, a, j, max(0.0, t - t0))


def jerk_changes(tl):
    """The times where arcsim's jerk changes, located between the samples from the accelerations
    (exact when one change falls between two samples)."""
    t, a, j = tl[:, 0], tl[:, 3], tl[:, 4]
    out = []
    for i in np.nonzero(j[1:] != j[:-1])[0]:
        dt = t[i + 1] - t[i]
        tau = (a[i + 1] - a[i] - j[i + 1] * dt) / (j[i] - j[i + 1])
        out.append(t[i] + min(max(tau, 0.0), dt))
    return np.array(out)


def stage_nodes(t0, t1, changes, m):
    """m pieces for a stage [t0, t1]: at arcsim's own jerk changes inside it where it has at most
    m - 1 (else merging its shortest neighbours), then the longest pieces halved."""
    inner = changes[(changes > t0 + 1e-9) & (changes < t1 - 1e-9)]
    edges = [t0] + sorted(inner) + [t1]
    while len(edges) - 1 > m:
        lengths = np.diff(edges)
        pair = lengths[:-1] + lengths[1:]
        del edges[1 + int(np.argmin(pair))]
    while len(edges) - 1 < m:
        q = int(np.argmax(np.diff(edges)))
        edges.insert(q + 1, 0.5 * (edges[q] + edges[q + 1]))
    return edges[:-1]


def node_times(p, result, tl):
    """arcsim's time of every node of the chain: stage edges from its result, pieces at its jerk
    changes."""
    layers = result["layers"]
    changes = jerk_changes(tl)
    times = []
    for kind, k, m in p.stages():
        if kind == "run_up":
            t0, t1 = 0.0, layers[0]["t_start_s"]
        elif kind == "beam":
            t0, t1 = layers[k]["t_start_s"], layers[k]["t_end_s"]
        else:
            t0, t1 = layers[k - 1]["t_end_s"], layers[k]["t_start_s"]
        times.extend(stage_nodes(t0, t1, changes, m))
    times.append(layers[-1]["t_end_s"])
    return np.array(times)


# ----------------------------------------------------------------------------------------------
# The NLP


class Watch(ca.Callback):
    """IPOPT's iteration callback: keeps the best iterate whose constraints hold to `FEAS` (by the
    total duration, the jerk penalty left out) and stops IPOPT once that best has not improved by
    `STALL_REL` (relative) for `STALL_ITERS` iterations, once it is at most GAP/10 longer than the
    start (IPOPT's iterates may first leave the start uphill; stopped there, the check would be
    weak, so it runs on, to its own tolerances, until it is back near or below it). On
    these problems the total settles long before IPOPT's dual tolerances are met (the problem is
    degenerate where pieces shrink to nothing), and the iterations after that cost most of the
    time."""

    def __init__(self, nx, lbg, ubg, h_slice, start_total):
        ca.Callback.__init__(self)
        self.start_total = start_total
        self.nx, self.ng = nx, len(lbg)
        self.lbg, self.ubg, self.h_slice = lbg, ubg, h_slice
        self.best, self.best_total, self.best_iter, self.iter = None, np.inf, 0, 0
        self.construct("watch", {})

    def get_n_in(self):
        return ca.nlpsol_n_out()

    def get_n_out(self):
        return 1

    def get_name_in(self, i):
        return ca.nlpsol_out(i)

    def get_name_out(self, i):
        return "ret"

    def get_sparsity_in(self, i):
        name = ca.nlpsol_out(i)
        if name == "f":
            return ca.Sparsity.scalar()
        if name in ("x", "lam_x"):
            return ca.Sparsity.dense(self.nx)
        if name in ("g", "lam_g"):
            return ca.Sparsity.dense(self.ng)
        return ca.Sparsity(0, 0)

    def eval(self, arg):
        self.iter += 1
        x = np.array(arg[0]).ravel()
        g = np.array(arg[2]).ravel()
        viol = max(0.0, float(np.max(self.lbg - g)), float(np.max(g - self.ubg)))
        total = float(np.sum(x[self.h_slice]))
        if viol <= FEAS and total < self.best_total:
            if total < self.best_total * (1.0 - STALL_REL):
                self.best_iter = self.iter
            self.best, self.best_total = x.copy(), total
        settled = self.iter - self.best_iter >= STALL_ITERS
        near_start = self.best_total < self.start_total * (1.0 + GAP / 10)
        return [1 if settled and near_start else 0]


def solve(p, result, tl, log, extra=None):
    stages = p.stages()
    kinds, layer, first_piece = [], [], []
    for s, (kind, k, m) in enumerate(stages):
        first_piece.append(len(kinds))
        kinds.extend([kind] * m)
        layer.extend([k] * m)
    N = len(kinds)  # intervals; nodes 0..N
    nv = 3 * (N + 1) + 2 * N
    w = ca.SX.sym("w", nv)
    X = w[0 : 3 * (N + 1)].reshape((3, N + 1))
    xs, vs, as_ = X[0, :].T, X[1, :].T, X[2, :].T
    jerk = w[3 * (N + 1) : 3 * (N + 1) + N]
    h = w[3 * (N + 1) + N :]

    # Bounds per node and per interval.
    inf = np.inf
    lbx = np.full((3, N + 1), -inf)
    ubx = np.full((3, N + 1), inf)
    lbj, ubj = np.full(N, -p.J), np.full(N, p.J)
    lbh, ubh = np.zeros(N), np.full(N, inf)
    # Bernstein middle coefficient bounds on the speed, per interval.
    lbb, ubb = np.full(N, -inf), np.full(N, inf)
    amin = min(p.A, p.D)

    def arc_node(n, d):
        v_lo, v_hi = (0.0, p.V) if d > 0 else (-p.V, 0.0)
        a_lo, a_hi = (-p.D, p.A) if d > 0 else (-p.A, p.D)
        lbx[1, n], ubx[1, n] = max(lbx[1, n], v_lo), min(ubx[1, n], v_hi)
        lbx[2, n], ubx[2, n] = max(lbx[2, n], a_lo), min(ubx[2, n], a_hi)

    for i in range(N):
        k = layer[i]
        kind = kinds[i]
        if kind == "turn":
            lbx[1, i], ubx[1, i] = max(lbx[1, i], -p.V), min(ubx[1, i], p.V)
            lbx[2, i], ubx[2, i] = max(lbx[2, i], -amin), min(ubx[2, i], amin)
            lbb[i], ubb[i] = -p.V, p.V
        else:
            d = p.dir[p.arc[k]]
            arc_node(i, d)
            arc_node(i + 1, d)
            lbb[i], ubb[i] = (0.0, p.V) if d > 0 else (-p.V, 0.0)
        if kind == "beam":
            for n in (i, i + 1):
                lbx[0, n] = max(lbx[0, n], p.lo[k])
                ubx[0, n] = min(ubx[0, n], p.hi[k])
                if p.rest_beam[k]:
                    lbx[1:, n] = 0.0
                    ubx[1:, n] = 0.0
            if p.rest_beam[k]:
                lbj[i] = ubj[i] = 0.0
        if kind == "run_up" and i == 0:
            lbx[1:, 0] = 0.0
            ubx[1:, 0] = 0.0
    # Arc changes end at rest on both sides (the beams there are at rest): nothing more to add.

    # Constraints: defects, Bernstein speed, stage sums.
    x1, v1, a1 = step(xs[:-1], vs[:-1], as_[:-1], jerk, h)
    g = [xs[1:] - x1, vs[1:] - v1, as_[1:] - a1, vs[:-1] + as_[:-1] * h / 2]
    lbg = [np.zeros(N)] * 3 + [lbb]
    ubg = [np.zeros(N)] * 3 + [ubb]
    rows, cols_, lo_s, hi_s = [], [], [], []
    for s, (kind, k, m) in enumerate(stages):
        if kind == "beam":
            lo_s.append(p.t_irr[k])
            hi_s.append(p.t_irr[k])
        elif kind in ("switch", "turn"):
            lo_s.append(p.elst[k])
            hi_s.append(inf)
        else:
            continue
        r = len(lo_s) - 1
        for i in range(first_piece[s], first_piece[s] + m):
            rows.append(r)
            cols_.append(i)
    S = ca.DM(ca.Sparsity.triplet(len(lo_s), N, rows, cols_), 1.0)
    g.append(ca.mtimes(S, h))
    lbg.append(np.array(lo_s))
    ubg.append(np.array(hi_s))
    G = ca.vertcat(*g)
    f = ca.sum1(h) + REG * ca.sumsqr(jerk)

    # Start: arcsim's timeline at the nodes.
    tn = node_times(p, result, tl)
    x0 = np.array([state_at(tl, t) for t in tn]).T  # 3 x (N+1)
    h0 = np.diff(tn)
    j0 = np.where(h0 > 0, np.diff(x0[2]) / np.where(h0 > 0, h0, 1.0), 0.0)
    j0 = np.clip(j0, lbj, ubj)
    h0 = np.clip(h0, lbh, ubh)
    x0 = np.clip(x0, lbx, ubx)
    w0 = np.concatenate([x0.T.reshape(-1), j0, h0])
    lbw = np.concatenate([lbx.T.reshape(-1), lbj, lbh])
    ubw = np.concatenate([ubx.T.reshape(-1), ubj, ubh])

    opts = {
        # `Watch` stops IPOPT once the total has settled; these tolerances rarely end it first.
        "ipopt.tol": 1e-6,
        "ipopt.constr_viol_tol": 1e-10,
        "ipopt.max_iter": 2000,
        "ipopt.max_wall_time": MAX_WALL_S,
        "ipopt.print_level": 0,
        "ipopt.sb": "yes",
        "ipopt.bound_relax_factor": 0.0,
        "ipopt.mu_strategy": "adaptive",
        # Start where arcsim is (its timeline is feasible and near a local optimum): a small
        # barrier parameter, and the start moved only slightly off the bounds it touches.
        "ipopt.mu_init": 1e-4,
        "ipopt.bound_push": 1e-6,
        "ipopt.bound_frac": 1e-6,
        "ipopt.linear_solver": "mumps",
        "print_time": False,
    }
    opts.update(extra or {})
    t_build = time.time()
    lbg, ubg = np.concatenate(lbg), np.concatenate(ubg)
    watch = Watch(nv, lbg, ubg, slice(3 * (N + 1) + N, nv), float(np.sum(h0)))
    opts["iteration_callback"] = watch
    nlp = ca.nlpsol("oracle", "ipopt", {"x": w, "f": f, "g": G}, opts)
    sol = nlp(x0=w0, lbx=lbw, ubx=ubw, lbg=lbg, ubg=ubg)
    stats = nlp.stats()
    log(
        f"  ipopt: {stats['return_status']}, {stats['iter_count']} iterations "
        f"(best at {watch.best_iter}), "
        f"{time.time() - t_build:.1f} s, "
        f"{N} intervals, {nv} variables"
    )
    wopt = np.array(sol["x"]).ravel() if watch.best is None else watch.best
    Xo = wopt[0 : 3 * (N + 1)].reshape(N + 1, 3)
    return {
        "status": stats["return_status"],
        "start": Xo[0],
        "nodes": Xo,
        "jerk": wopt[3 * (N + 1) : 3 * (N + 1) + N],
        "h": wopt[3 * (N + 1) + N :],
        "kinds": kinds,
        "layer": layer,
    }


# ----------------------------------------------------------------------------------------------
# Repair: IPOPT leaves defects of ~1e-10 at every join, and re-integrating from the start adds
# them up (a speed error grows into an angle error over the whole delivery). Every beam's pieces are
# scaled to last its irradiation time exactly. Every motion stage
# between beams (switch, arc change, run-up) is re-aimed, in sequence, at IPOPT's state at its end
# from the state the re-integration actually reaches: a least-norm Newton correction of its jerks
# and durations (those not on a bound). The beams keep their pieces. The result is checked by
# `verify` like any other.

_stage_maps = {}


def stage_map(m):
    """CasADi function: (start state, jerks, durations) of m pieces -> end state, Jacobian."""
    if m not in _stage_maps:
        s0 = ca.SX.sym("s0", 3)
        j = ca.SX.sym("j", m)
        h = ca.SX.sym("h", m)
        x, v, a = s0[0], s0[1], s0[2]
        for i in range(m):
            x, v, a = step(x, v, a, j[i], h[i])
        end = ca.vertcat(x, v, a)
        z = ca.vertcat(j, h)
        _stage_maps[m] = ca.Function("stage", [s0, z], [end, ca.jacobian(end, z)])
    return _stage_maps[m]


def least_norm_step(jac, r, z, lo, hi):
    """z + dz with jac @ dz = -r and |dz| least, z + dz within [lo, hi]: the variables that would
    leave their bounds stay where they are (an active set, tried again without them)."""
    free = np.ones(len(z), dtype=bool)
    while free.any():
        jf = jac[:, free]
        dz = np.zeros(len(z))
        dz[free] = -jf.T @ np.linalg.lstsq(jf @ jf.T, r, rcond=1e-14)[0]
        out = free & ((z + dz < lo) | (z + dz > hi))
        if not out.any():
            return z + dz
        free &= ~out
    return z


def repair(p, s):
    worst = 0.0
    h = np.maximum(s["h"], 0.0)
    jerk = np.clip(s["jerk"], -p.J, p.J)
    kinds, nodes = s["kinds"], s["nodes"]
    cur = np.array(s["start"], dtype=float)
    i = 0
    N = len(h)
    while i < N:
        m = 1
        while i + m < N and kinds[i + m] == kinds[i] and s["layer"][i + m] == s["layer"][i]:
            m += 1
        if kinds[i] == "beam" and h[i : i + m].sum() > 0.0:
            h[i : i + m] *= p.t_irr[s["layer"][i]] / h[i : i + m].sum()
        if kinds[i] != "beam":
            target = nodes[i + m]
            f = stage_map(m)
            lo = np.concatenate([np.full(m, -p.J), np.zeros(m)])
            hi = np.concatenate([np.full(m, p.J), np.full(m, np.inf)])
            for _ in range(6):
                z = np.concatenate([jerk[i : i + m], h[i : i + m]])
                end, jac = f(cur, z)
                r = np.array(end).ravel() - target
                if np.max(np.abs(r)) < 1e-14:
                    break
                z = least_norm_step(np.array(jac), r, z, lo, hi)
                jerk[i : i + m], h[i : i + m] = z[:m], z[m:]
            end, _ = f(cur, np.concatenate([jerk[i : i + m], h[i : i + m]]))
            worst = max(worst, float(np.max(np.abs(np.array(end).ravel() - target))))
        for q in range(i, i + m):
            cur = np.array(step(cur[0], cur[1], cur[2], jerk[q], h[q]))
        i += m
    return dict(s, h=h, jerk=jerk, repair_residual=worst)


# ----------------------------------------------------------------------------------------------
# The independent check


def critical_times(v, a, j, h, tau):
    """Sample times of one interval: `tau` spread over [0, h], and where the speed has its
    extremum (a = 0) or is zero (the angle's extremum), so the checks are exact there."""
    ts = list(h * tau)
    if j != 0.0 and 0.0 < -a / j < h:
        ts.append(-a / j)
    for r in np.roots([j / 2, a, v]) if (j != 0.0 or a != 0.0) else []:
        if abs(r.imag) < 1e-15 and 0.0 < r.real < h:
            ts.append(r.real)
    return np.array(ts)


def verify(p, s):
    """Re-integrate the jerks and durations from the start state and check every limit densely.
    Returns (total, []) or (None, [what failed])."""
    fails = []
    J, A, D, V = p.J, p.A, p.D, p.V
    h, jerk, kinds, layer = s["h"], s["jerk"], s["kinds"], s["layer"]
    if np.any(h < 0):
        fails.append(f"negative duration {h.min():.3g}")
    if np.any(np.abs(jerk) > J + TOL):
        fails.append(f"jerk {np.abs(jerk).max():.9g} > J")
    x, v, a = (float(c) for c in s["start"])
    if kinds[0] == "run_up" and (abs(v) > TOL or abs(a) > TOL):
        fails.append("run-up does not start at rest")
    if kinds[0] != "run_up":
        k0 = layer[0]
        if p.rest_beam[k0] and (abs(v) > TOL or abs(a) > TOL):
            fails.append("first beam not at rest")
    beam_time = np.zeros(p.n)
    gap_time = np.zeros(p.n)
    tau = np.linspace(0.0, 1.0, SAMPLES + 2)
    worst = {}

    def note(what, amount, where):
        if amount > TOL and amount > worst.get(what, (0, None))[0]:
            worst[what] = (amount, where)

    for i in range(len(h)):
        k, kind = layer[i], kinds[i]
        xs, vs_, as_ = step(x, v, a, jerk[i], critical_times(v, a, jerk[i], h[i], tau))
        where = f"interval {i} ({kind}, layer {k})"
        if kind == "turn":
            note("speed above V", np.max(np.abs(vs_)) - V, where)
            note("accel above min(A, D)", np.max(np.abs(as_)) - min(A, D), where)
            gap_time[k] += h[i]
        else:
            d = p.dir[p.arc[k]]
            note("speed above V", np.max(d * vs_) - V, where)
            note("reversal (speed below 0)", -np.min(d * vs_), where)
            note("accel above A", np.max(d * as_) - A, where)
            note("decel above D", -np.min(d * as_) - D, where)
            if kind == "beam":
                beam_time[k] += h[i]
                note("outside window (low)", p.lo[k] - np.min(xs), where)
                note("outside window (high)", np.max(xs) - p.hi[k], where)
                if p.rest_beam[k]:
                    note("rest beam moves", max(np.max(np.abs(vs_)), np.max(np.abs(as_))), where)
            elif kind == "switch":
                gap_time[k] += h[i]
        x, v, a = (float(c) for c in step(x, v, a, jerk[i], h[i]))
    for what, (amount, where) in worst.items():
        fails.append(f"{what} by {amount:.3g} at {where}")
    bad = np.abs(beam_time - p.t_irr) > TOL
    if bad.any():
        k = int(np.argmax(np.abs(beam_time - p.t_irr)))
        fails.append(f"irradiation time off by {beam_time[k] - p.t_irr[k]:.3g} s (layer {k})")
    short = gap_time[1:] < p.elst[1:] - TOL
    if short.any():
        k = 1 + int(np.argmax(p.elst[1:] - gap_time[1:]))
        fails.append(f"switch into layer {k} lasts {gap_time[k]:.9g} s < ELST {p.elst[k]} s")
    if fails:
        return None, fails
    return float(np.sum(h)), []


# ----------------------------------------------------------------------------------------------


def run_case(args, name, plan, machine, ends, workdir, log):
    repo = args.repo
    plan_path = os.path.join(repo, plan)
    out_json = os.path.join(workdir, name.replace("/", "_") + f"-{ends}.json")
    out_csv = out_json[:-5] + ".csv"
    cmd = [
        args.arcsim,
        "simulate",
        plan_path,
        "--motion",
        "free",
        "--arc-ends",
        ends,
        "--json",
        out_json,
        "--csv",
        out_csv,
        "--dt",
        "0.005",
    ]
    if machine:
        cmd += ["--machine", os.path.join(repo, machine)]
    t0 = time.time()
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError(f"arcsim failed: {' '.join(cmd)}\n{r.stdout}{r.stderr}")
    t_arcsim = time.time() - t0
    with open(out_json) as f:
        result = json.load(f)
    with open(plan_path) as f:
        plan_json = json.load(f)
    p = Problem(result, plan_json, ends)
    tl = read_timeline(out_csv)
    arcsim_total = result["total_s"]
    log(f"{name} ({ends} ends): {p.n} layers, arcsim {arcsim_total:.4f} s ({t_arcsim:.1f} s)")
    t1 = time.time()
    s = repair(p, solve(p, result, tl, log))
    total, fails = verify(p, s)
    log(f"  stages re-aimed to {s['repair_residual']:.2g}; verified total {total}")
    t_oracle = time.time() - t1
    if fails:
        log("  not verified: " + "; ".join(fails))
    row = {
        "case": name,
        "ends": ends,
        "layers": p.n,
        "arcsim_total_s": arcsim_total,
        "oracle_total_s": total,
        "ipopt_status": s["status"],
        "verified": total is not None,
        "failures": fails,
        "gap_percent": None if total is None else 100.0 * (total - arcsim_total) / arcsim_total,
        "passes": total is not None and arcsim_total <= total * (1.0 + GAP),
        "arcsim_s": t_arcsim,
        "oracle_s": t_oracle,
    }
    return row


def run_logged(args, case, workdir):
    """One case in a worker process: (row, its log lines)."""
    lines = []
    row = run_case(args, *case, workdir, lines.append)
    return row, lines


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--arcsim", required=True, help="the arcsim binary")
    ap.add_argument("--repo", required=True, help="the repository (plans, scenarios)")
    ap.add_argument("--out", required=True, help="where to write the results (JSON)")
    ap.add_argument("--jobs", type=int, default=1, help="cases solved at once")
    ap.add_argument("--only", nargs="*", help="cases to run: NAME (both ends) or NAME:ENDS")
    args = ap.parse_args()

    cases = CASES
    if args.only:
        cases = [
            c
            for c in CASES + LONG_CASES + OTHER_MACHINE_CASES
            if c[0] in args.only or f"{c[0]}:{c[3]}" in args.only
        ]
    t0 = time.time()
    rows = {}
    with tempfile.TemporaryDirectory() as workdir:
        # The largest plans first, so that the workers finish together.
        order = sorted(
            range(len(cases)), key=lambda q: -os.path.getsize(os.path.join(args.repo, cases[q][1]))
        )
        with ProcessPoolExecutor(max_workers=max(1, args.jobs)) as pool:
            futures = {pool.submit(run_logged, args, cases[q], workdir): q for q in order}
            for fut in as_completed(futures):
                row, lines = fut.result()
                rows[futures[fut]] = row
                print("\n".join(lines), flush=True)
    rows = [rows[q] for q in range(len(cases))]
    with open(args.out, "w") as f:
        json.dump(
            {"casadi": ca.__version__, "gap": GAP, "tolerance": TOL, "cases": rows}, f, indent=1
        )
    print()
    print(
        f"free motion against an independent optimiser (CasADi {ca.__version__} + IPOPT, "
        f"{time.time() - t0:.0f} s); a case fails when the oracle is shorter by more than "
        f"{100 * GAP:.2f} %"
    )
    print(
        f"{'case':<20} {'ends':<5} {'layers':>6} {'arcsim (s)':>11} {'oracle (s)':>11} "
        f"{'gap %':>8} {'time (s)':>8}  verdict"
    )
    ok = True
    for r in rows:
        oracle = "-" if r["oracle_total_s"] is None else f"{r['oracle_total_s']:.4f}"
        gap = "-" if r["gap_percent"] is None else f"{r['gap_percent']:+.4f}"
        verdict = (
            "ok" if r["passes"] else ("NOT VERIFIED" if not r["verified"] else "ARCSIM BEATEN")
        )
        ok &= r["passes"]
        print(
            f"{r['case']:<20} {r['ends']:<5} {r['layers']:>6} {r['arcsim_total_s']:>11.4f} "
            f"{oracle:>11} {gap:>8} "
            f"{r['arcsim_s'] + r['oracle_s']:>8.1f}  {verdict}"
        )
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
