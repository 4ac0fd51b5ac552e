#!/usr/bin/env python3
"""PyTorch reference of the paper's hybrid PINN, for timing and accuracy beside liftwatch.

Reads the aligned CSV that `liftwatch simulate` writes (DATA.md section 2, extra columns
ignored) and the elevator description (DATA.md section 3), builds the features of MODEL.md,
and fits the physical parameters theta and the 3-16-16-2 tanh correcting network together,
as the paper does, with either

  --optimizer lbfgs   torch.optim.LBFGS, strong Wolfe line search, history 30
  --optimizer adam    the paper's schedule: Adam, full batch, lr 1e-3, 20,000 epochs

It prints one JSON line (optimizer, fit wall and CPU seconds, iterations, train and held-out
RMS of r_U over moving samples, fitted theta). float64, one thread. See bench/README.md for
what is and is not identical to liftwatch's fit.

Optional dependency: `pip install torch numpy`.
"""

import argparse
import csv
import json
import math
import os
import sys
import time

try:
    import tomllib  # Python >= 3.11
except ImportError:  # pragma: no cover
    tomllib = None

import numpy as np

G = 9.81
LN2 = math.log(2.0)
NAMES = ["delta_m", "m0", "f_c", "c_visc", "kd", "ke", "u0", "alpha_down", "m_rope"]
SIGNED = [True, False, False, False, False, False, False, False, True]

# Settings shared with liftwatch (crates/liftwatch/src/features, model/train.rs).
V_MOVE = 0.05            # |v| above which the car moves (m/s)
L_REF_WINDOW = 30.0      # running mean of at most 30 door-closed standstill readings
MAX_STEP_S = 10.0        # neighbours further apart are not neighbours
A_L_MAX = 3.0            # implausible load-path acceleration (m/s^2)
PHASE_ACCEL = 0.1        # |a_v| above which a sample is starting/braking (m/s^2)
BETA_TRANSIENT, BETA_CRUISE, BETA_REF_LAMBDA = 0.3, 0.95, 0.5
LAMBDA_MAX = 1.5
LOAD_BINS = 200.0        # standstill samples aggregated per 0.5 % of rated load
STANDSTILL_SHARE = 0.1   # total standstill weight relative to the moving weight
DRIVE_OFF_SHARE = 0.005
INTERPOLATION_NOISE_SHARE = 0.005
NET_OUTPUT_SIGMAS = 3.0


# ----------------------------------------------------------------------------- input

def read_elevator(path):
    with open(path, "rb") as f:
        text = f.read().decode()
    if tomllib is not None:
        e = tomllib.loads(text)
    else:  # flat key = value files only
        e = {}
        for line in text.splitlines():
            line = line.split("#", 1)[0].strip()
            if "=" in line:
                k, v = line.split("=", 1)
                try:
                    e[k.strip()] = float(v)
                except ValueError:
                    e[k.strip()] = v.strip().strip('"')
    m_r = float(e["rated_load_kg"])
    return {
        "m_r": m_r,
        "v_r": float(e["rated_speed_mps"]),
        "floors": int(e["floors"]),
        "car_mass": float(e.get("car_mass_kg", 1.2 * m_r)),
        "cw_ratio": float(e.get("counterweight_ratio", 0.45)),
        "u_r": float(e.get("rated_voltage_v", 380.0)),
    }


def read_aligned(path):
    cols = ["time", "speed", "direction", "voltage", "load", "door", "floor"]
    out = {c: [] for c in cols}
    with open(path, newline="") as f:
        r = csv.reader(f)
        header = next(r)
        idx = [header.index(c) for c in cols]
        for row in r:
            for c, i in zip(cols, idx):
                s = row[i] if i < len(row) else ""
                try:
                    out[c].append(float(s) if s not in ("", "NaN", "nan") else math.nan)
                except ValueError:
                    out[c].append(math.nan)
    return {c: np.asarray(v, dtype=np.float64) for c, v in out.items()}


# -------------------------------------------------------------------------- features

def prior(e):
    """Prior centre and widths, as liftwatch's PhysParams::prior_centre and Prior::for_elevator."""
    m_r, v_r, u_r = e["m_r"], e["v_r"], e["u_r"]
    car, cw = e["car_mass"], e["cw_ratio"]
    f_c = 0.015 * (car + m_r) * G
    kd = 0.07 * u_r / ((1.0 - cw) * m_r * G)
    centre = {
        "delta_m": -cw * m_r,
        "m0": 1.15 * (car + car + cw * m_r),
        "f_c": f_c,
        "c_visc": 0.5 * f_c / v_r,
        "kd": kd,
        "ke": 0.85 * u_r / v_r,
        "u0": 0.02 * u_r,
        "alpha_down": 1.0,
        "m_rope": 0.0,
    }
    c = centre
    sd = [0.25 * m_r, 0.5 * c["m0"], c["f_c"], c["c_visc"], c["kd"], 0.5 * c["ke"],
          max(c["u0"], 5.0), 0.3, 0.5 * m_r]
    return np.array([c[n] for n in NAMES]), np.array(sd)


def features(d, e, p_platform):
    """One pass over the aligned series: v, s, lambda, a (fused), d2v, d2u, q.

    A batch transcription of liftwatch's FeatureTracker for data with a door signal (the
    door-dropout rules and the direction memory are left out)."""
    n = len(d["time"])
    t, speed, dirn, load, door = d["time"], d["speed"], d["direction"], d["load"], d["door"]
    v = np.where(np.isfinite(dirn), np.sign(dirn), np.nan) * speed
    s = np.where(np.abs(v) > V_MOVE, np.sign(v), 0.0)
    s[~np.isfinite(v)] = 0.0
    load = np.where((load >= -20.0) & (load <= 200.0), load, np.nan)
    vb = np.where(s == 0, 0.0, v)            # a neighbour at rest counts as v = 0
    vb[~np.isfinite(v)] = np.nan
    ok_prev = np.zeros(n, bool)
    ok_prev[1:] = (np.diff(t) > 0) & (np.diff(t) <= MAX_STEP_S)
    ok_next = np.zeros(n, bool)
    ok_next[:-1] = ok_prev[1:]
    lam = np.full(n, np.nan)
    a_l = np.full(n, np.nan)
    trip_ref = np.full(n, np.nan)
    ref_mean, ref_n = math.nan, 0.0
    rest_load, rest_time = math.nan, -1e300
    trip_l = None
    rest_speed = 0.2 * V_MOVE
    for i in range(n):
        still = np.isfinite(speed[i]) and speed[i] <= rest_speed and np.isfinite(load[i])
        if still:
            rest_load, rest_time = load[i], t[i]
        if door[i] > 0.5:
            ref_mean, ref_n = math.nan, 0.0
        if not door[i] > 0.5 and still:
            ref_n = min(ref_n + 1.0, L_REF_WINDOW)
            m = ref_mean if math.isfinite(ref_mean) else load[i]
            ref_mean = m + (load[i] - m) / ref_n
        if s[i] != 0:
            if trip_l is None:
                if i > 0 and ok_prev[i] and s[i - 1] == 0 and np.isfinite(v[i - 1]):
                    if ref_n > 0:
                        trip_l = ref_mean
                    elif 0 <= t[i] - rest_time <= MAX_STEP_S:
                        trip_l = rest_load
                    else:
                        trip_l = math.nan
                else:
                    trip_l = math.nan
            trip_ref[i] = trip_l
            lam[i] = trip_l / 100.0
        else:
            trip_l = None
            lam[i] = (ref_mean if ref_n > 0 else load[i]) / 100.0
    lam = np.clip(lam, 0.0, LAMBDA_MAX)
    # a_v: central difference, one-sided at an edge
    a_v = np.full(n, np.nan)
    for i in range(n):
        if not np.isfinite(v[i]):
            continue
        pp = i > 0 and ok_prev[i] and np.isfinite(vb[i - 1])
        nn = i + 1 < n and ok_next[i] and np.isfinite(vb[i + 1])
        if pp and nn:
            a_v[i] = (vb[i + 1] - vb[i - 1]) / (t[i + 1] - t[i - 1])
        elif pp:
            a_v[i] = (vb[i] - vb[i - 1]) / (t[i] - t[i - 1])
        elif nn:
            a_v[i] = (vb[i + 1] - vb[i]) / (t[i + 1] - t[i])
    moving_closed = (s != 0) & (door <= 0.5) & np.isfinite(lam)
    inert = lam + p_platform                 # k = 1: the cell under the platform
    a_l = np.where(moving_closed, G * (load - trip_ref) / 100.0 / inert, np.nan)
    a_l[np.abs(a_l) > A_L_MAX] = np.nan
    along = a_v * s
    transient = (s != 0) & (np.abs(along) > PHASE_ACCEL)
    beta_ref = np.where(transient, BETA_TRANSIENT, BETA_CRUISE)
    scale = inert / (BETA_REF_LAMBDA + p_platform)
    beta = 1.0 / (1.0 + (1.0 / beta_ref - 1.0) * scale * scale)
    beta = np.where(np.isfinite(beta), beta, beta_ref)
    a = np.where(np.isfinite(a_v) & np.isfinite(a_l), beta * a_v + (1 - beta) * a_l,
                 np.where(np.isfinite(a_v), a_v, a_l))
    a = np.where(s == 0, 0.0, a)
    a[~np.isfinite(v)] = np.nan
    d2v = np.full(n, np.nan)
    d2u = np.full(n, np.nan)
    inner = np.zeros(n, bool)
    inner[1:-1] = ok_prev[1:-1] & ok_next[1:-1]
    idx = np.nonzero(inner)[0]
    d2v[idx] = v[idx - 1] - 2 * v[idx] + v[idx + 1]
    d2u[idx] = d["voltage"][idx - 1] - 2 * d["voltage"][idx] + d["voltage"][idx + 1]
    fl = d["floor"]
    q = np.where(np.isfinite(fl), np.clip((fl - 1.0) / (e["floors"] - 1), 0.0, 1.0) - 0.5, 0.0)
    return {"v": v, "s": s, "lam": lam, "a": a, "a_v": a_v, "d2v": d2v, "d2u": d2u, "q": q,
            "u": d["voltage"], "trip_ref": trip_ref, "load": load, "door": door, "t": t}


def fit_platform_ratio(d, e, default=0.15):
    """p of the load cell with k = 1: S = integral of g(L - L_ref)/100 dt = (lambda + p) dv over
    segments between near-zero-acceleration anchors (standstill or cruising), a simpler
    version of liftwatch's fit_load_cell (k is not tested against 1)."""
    f = features(d, e, default)
    n = len(f["t"])
    num = den = 0.0
    segs = 0
    i = 0
    while i < n:
        if f["s"][i] == 0 or not np.isfinite(f["trip_ref"][i]):
            i += 1
            continue
        j = i
        while j < n and f["s"][j] != 0:
            j += 1
        # trip i..j-1, bracketed by standstill samples i-1 and j
        if i == 0 or j >= n or np.any(f["door"][i - 1:j + 1] > 0.5):
            i = j
            continue
        lref, lam = f["trip_ref"][i], f["lam"][i]
        idx = np.arange(i - 1, j + 1)
        vv = np.where(f["s"][idx] == 0, 0.0, f["v"][idx])
        acc = G * (f["load"][idx] - lref) / 100.0
        if not (np.all(np.isfinite(vv)) and np.all(np.isfinite(acc))):
            i = j
            continue
        dv = np.diff(vv)
        anchors = [0] + [k for k in range(1, len(idx) - 1)
                         if abs(dv[k - 1]) < 0.03 and abs(dv[k]) < 0.03] + [len(idx) - 1]
        for a0, a1 in zip(anchors[:-1], anchors[1:]):
            dvs = vv[a1] - vv[a0]
            if abs(dvs) < 0.2:
                continue
            tt = f["t"][idx][a0:a1 + 1]
            sint = float(np.sum(0.5 * (acc[a0:a1] + acc[a0 + 1:a1 + 1]) * np.diff(tt)))
            num += (sint - lam * dvs) * dvs
            den += dvs * dvs
            segs += 1
        i = j
    if segs < 5 or den <= 0:
        return default
    return float(np.clip(num / den, 0.01, 2.0))


def observations(f, e, ke_prior):
    """Moving rows one by one with interpolation weights; standstill rows averaged per load bin."""
    ok = np.isfinite(f["v"]) & np.isfinite(f["lam"]) & np.isfinite(f["a"]) & np.isfinite(f["u"])
    mv = ok & (f["s"] != 0)
    rs = ok & (f["s"] == 0)
    w = interpolation_weights(f, e, ke_prior)
    obs = {k: f[k][mv] for k in ("s", "v", "lam", "a", "q", "u")}
    obs["w"] = w[mv]
    n_mv = int(mv.sum())
    rest_u = f["u"][rs]
    drive_off = np.median(rest_u) < DRIVE_OFF_SHARE * np.median(obs["u"]) if rest_u.size else True
    if not drive_off:
        rest_w = STANDSTILL_SHARE * obs["w"].sum() / rest_u.size
        b = np.round(f["lam"][rs] * LOAD_BINS).astype(np.int64)
        ub = np.unique(b)
        cnt = np.array([np.sum(b == k) for k in ub], dtype=np.float64)
        lam_b = np.array([f["lam"][rs][b == k].mean() for k in ub])
        u_b = np.array([rest_u[b == k].mean() for k in ub])
        z = np.zeros(ub.size)
        obs = {"s": np.concatenate([obs["s"], z]), "v": np.concatenate([obs["v"], z]),
               "lam": np.concatenate([obs["lam"], lam_b]), "a": np.concatenate([obs["a"], z]),
               "q": np.concatenate([obs["q"], z]), "u": np.concatenate([obs["u"], u_b]),
               "w": np.concatenate([obs["w"], cnt * rest_w])}
    return obs, n_mv, bool(drive_off)


# ----------------------------------------------------------------------------- model

def build(torch, e, seed):
    torch.manual_seed(seed)
    net = torch.nn.Sequential(
        torch.nn.Linear(3, 16), torch.nn.Tanh(),
        torch.nn.Linear(16, 16), torch.nn.Tanh(),
        torch.nn.Linear(16, 2)).double()
    with torch.no_grad():  # liftwatch's init: Glorot-uniform hidden, zero biases and last layer
        for layer in (net[0], net[2]):
            torch.nn.init.xavier_uniform_(layer.weight)
            layer.bias.zero_()
        net[4].weight.zero_()
        net[4].bias.zero_()
    z = torch.zeros(9, dtype=torch.float64, requires_grad=True)
    return net, z


def physics(t, m_r, th, s, v, lam, a, q):
    """F, U_phys and phi of MODEL.md for theta `th` (NAMES order; tensors or floats)."""
    dm, m0, fc, c, kd, ke, u0, ad, mrope = th
    f = (m0 + lam * m_r) * a + (dm + lam * m_r + mrope * q) * G + fc * s + c * v
    phi = t.where(s > 0, t.ones_like(s), t.where(s < 0, ad, t.zeros_like(s)))
    u = u0 + ke * v.abs() + phi * kd * f * s
    return f, u, phi


def f_from_voltage(t, th, s, v, u, phi):
    """F_U: the force the measured voltage implies (moving samples; 1 in the denominator at rest)."""
    _, _, _, _, kd, ke, u0, _, _ = th
    den = phi * kd * s
    den = t.where(s != 0, den, t.ones_like(den))
    return (u - u0 - ke * v.abs()) / den


class Hybrid:
    def __init__(self, torch, e, mu, sd, sigma_u, sigma_f, seed):
        self.t = torch
        self.e = e
        self.mu = torch.tensor(mu)
        self.sd = torch.tensor(sd)
        self.signed = torch.tensor(SIGNED)
        self.sigma_u, self.sigma_f = sigma_u, sigma_f
        self.out_scale = torch.tensor([NET_OUTPUT_SIGMAS * sigma_u, NET_OUTPUT_SIGMAS * sigma_f],
                                      dtype=torch.float64)
        self.in_scale = torch.tensor([e["v_r"], 1.0, 1.0], dtype=torch.float64)
        self.net, self.z = build(torch, e, seed)
        self.box = None

    def params(self):
        return [self.z] + list(self.net.parameters())

    def theta(self, z=None):
        t = self.t
        z = self.z if z is None else z
        sp = t.nn.functional.softplus(z)
        return t.where(self.signed, self.mu + 0.1 * self.e["m_r"] * z, self.mu * sp / LN2)

    def delta(self, v, lam, a, hold=False):
        x = self.t.stack([v, lam, a], dim=1)
        if hold and self.box is not None:
            x = self.hold(x)
        return self.net(x / self.in_scale) * self.out_scale

    def physics(self, th, s, v, lam, a, q):
        return physics(self.t, self.e["m_r"], th, s, v, lam, a, q)

    def f_from_voltage(self, th, s, v, u, phi):
        return f_from_voltage(self.t, th, s, v, u, phi)

    def loss(self, o, w_u, w_f, w_p, w_n, motor_ref=None):
        """liftwatch's objective: [sum w_i (w_U rU^2/sU^2 + w_F rF^2/sF^2 + w_N (dU^2/sU^2 +
        dF^2/sF^2)) + w_P sum((theta-mu)/tau)^2] / sum w_i; r_F on moving samples only. F_U is
        evaluated with `motor_ref` (theta held, no gradient) when given."""
        th = self.theta()
        f, u, phi = self.physics(th, o["s"], o["v"], o["lam"], o["a"], o["q"])
        d = self.delta(o["v"], o["lam"], o["a"])
        du, df = d[:, 0], d[:, 1]
        r_u = o["u"] - u - du
        ref = th if motor_ref is None else motor_ref
        f_u = self.f_from_voltage(ref, o["s"], o["v"], o["u"], phi if motor_ref is None else
                                  self.t.where(o["s"] < 0, motor_ref[7], self.t.ones_like(o["s"])))
        moving = o["s"] != 0
        r_f = self.t.where(moving, f + df - f_u, self.t.zeros_like(f))
        iu2, if2 = 1.0 / self.sigma_u ** 2, 1.0 / self.sigma_f ** 2
        li = w_u * r_u ** 2 * iu2 + w_f * r_f ** 2 * if2 + w_n * (du ** 2 * iu2 + df ** 2 * if2)
        pri = (((th - self.mu) / self.sd) ** 2).sum()
        wsum = o["w"].sum()
        return ((o["w"] * li).sum() + w_p * pri) / wsum, r_u, moving

    def set_box(self, o):
        """Per-direction box of (v, lambda, a) the fit saw (liftwatch's net.domain)."""
        x = np.stack([o["v"].numpy(), o["lam"].numpy(), o["a"].numpy()], 1)
        self.box = {}
        for k, m in ((-1, x[:, 0] < 0), (0, x[:, 0] == 0), (1, x[:, 0] > 0)):
            if m.any():
                self.box[k] = (x[m].min(0), x[m].max(0))

    def hold(self, x):
        t = self.t
        xn = x.detach().numpy().copy()
        for k, (lo, hi) in self.box.items():
            m = (np.sign(xn[:, 0]) == k)
            xn[m] = np.clip(xn[m], lo, hi)
        return t.tensor(xn)


def rms_u(model, torch, f, hold, w=None):
    """RMS of r_U over moving samples with finite features; weighted by `w` when given."""
    ok = (np.isfinite(f["v"]) & np.isfinite(f["lam"]) & np.isfinite(f["a"]) & np.isfinite(f["u"])
          & (f["s"] != 0))
    T = lambda x: torch.tensor(x[ok], dtype=torch.float64)
    with torch.no_grad():
        th = model.theta()
        _, u, _ = model.physics(th, T(f["s"]), T(f["v"]), T(f["lam"]), T(f["a"]), T(f["q"]))
        d = model.delta(T(f["v"]), T(f["lam"]), T(f["a"]), hold=hold)
        r = T(f["u"]) - u - d[:, 0]
        if w is not None:
            ww = T(w)
            return float(torch.sqrt((ww * r ** 2).sum() / ww.sum())), int(ok.sum())
    return float(torch.sqrt((r ** 2).mean())), int(ok.sum())


def interpolation_weights(f, e, ke_prior):
    """liftwatch's weight of a moving sample: sigma^2/(sigma^2 + (Ke d2v/8)^2 + (d2u/8)^2)."""
    sig = INTERPOLATION_NOISE_SHARE * e["u_r"]
    ev = np.where(np.isfinite(f["d2v"]), ke_prior * f["d2v"] / 8.0, 0.0)
    eu = np.where(np.isfinite(f["d2u"]), f["d2u"] / 8.0, 0.0)
    return sig * sig / (sig * sig + ev * ev + eu * eu)


def infer(args, torch):
    """Batched inference of a liftwatch model on every sample of `--input`, as the paper's
    PyTorch would run its monitor: the network over all samples at once (inputs held to the
    model's box), the physics, r_U, r_F and the combined e. Times the inference alone (the
    tensors are built first), median of `--repeats`, in float32 and float64."""
    with open(args.infer) as fh:
        m = json.load(fh)
    e = read_elevator(args.elevator)
    d = read_aligned(args.input)
    f = features(d, e, m["features"]["load_cell_platform_ratio"])
    n = len(f["t"])
    th = m["parameters"]
    net = m["net"]
    w = np.asarray(net["weights"], dtype=np.float64)
    # liftwatch's layout (model/net.rs): W1 16x3, b1, W2 16x16, b2, W3 2x16, b3, row-major.
    shapes = [(16, 3), (16,), (16, 16), (16,), (2, 16), (2,)]
    parts, k = [], 0
    for sh in shapes:
        size = int(np.prod(sh))
        parts.append(w[k:k + size].reshape(sh))
        k += size
    # The network's inputs as liftwatch's net_inputs: (0, lambda to 0.001, 0) at rest.
    moving = f["s"] != 0
    lam = np.where(moving, f["lam"], np.round(f["lam"] * 1000.0) / 1000.0)
    x = np.stack([np.where(moving, f["v"], 0.0), lam, np.where(moving, f["a"], 0.0)], 1)
    side = (np.sign(np.where(moving, f["v"], 0.0)) + 1).astype(np.int64)   # box -1, 0, +1
    boxes = np.asarray(net["domain"]["boxes"], dtype=np.float64)             # [side][input][lo, hi]
    sig_u, sig_f = m["scales"]["sigma_u_v"], m["scales"]["sigma_f_n"]
    m_r = e["m_r"]
    out = {"samples": n, "moving": int(moving.sum()), "repeats": args.repeats}
    for name, dt in (("float32", torch.float32), ("float64", torch.float64)):
        T = lambda a: torch.tensor(np.asarray(a), dtype=dt)
        W = [T(p) for p in parts]
        lo, hi = T(boxes[:, :, 0])[torch.tensor(side)], T(boxes[:, :, 1])[torch.tensor(side)]
        xin, s, v, a, q, u = T(x), T(f["s"]), T(f["v"]), T(f["a"]), T(f["q"]), T(f["u"])
        lam_t = T(f["lam"])
        in_scale, out_scale = T(net["input_scale"]), T(net["output_scale"])
        theta = tuple(float(th[k2]) for k2 in NAMES)
        zero = torch.zeros_like(s)

        def network():
            xx = torch.minimum(torch.maximum(xin, lo), hi) / in_scale
            h = torch.tanh(xx @ W[0].T + W[1])
            h = torch.tanh(h @ W[2].T + W[3])
            return (h @ W[4].T + W[5]) * out_scale

        def step():
            dlt = network()
            f_pred, u_phys, phi = physics(torch, m_r, theta, s, v, lam_t, a, q)
            r_u = u - u_phys - dlt[:, 0]
            r_f = torch.where(s != 0, f_pred + dlt[:, 1] - f_from_voltage(torch, theta, s, v, u, phi),
                              zero)
            e_all = torch.sqrt(((r_u / sig_u) ** 2 + (r_f / sig_f) ** 2) / 2.0)
            return r_u, r_f, e_all

        def median_s(fn):
            times = []
            with torch.no_grad():
                fn()  # warm-up
                for _ in range(args.repeats):
                    t0 = time.perf_counter()
                    fn()
                    times.append(time.perf_counter() - t0)
            times.sort()
            return times[len(times) // 2]

        full, net_only = median_s(step), median_s(network)
        with torch.no_grad():
            r_u = step()[0].numpy()
        ok = moving & np.isfinite(r_u)
        out[name] = {
            "seconds": full,
            "samples_per_s": n / full,
            "network_only_samples_per_s": n / net_only,
            "rms_u_v_moving": float(np.sqrt(np.mean(r_u[ok].astype(np.float64) ** 2))),
        }
    print(json.dumps(out))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--input", required=True,
                    help="training aligned.csv (with --infer: the monitored one)")
    ap.add_argument("--elevator", required=True, help="elevator.toml")
    ap.add_argument("--test", action="append", default=[],
                    help="held-out directory holding aligned.csv (repeatable)")
    ap.add_argument("--optimizer", choices=["lbfgs", "adam"], default="lbfgs")
    ap.add_argument("--epochs", type=int, default=20000, help="Adam epochs (paper: 20,000)")
    ap.add_argument("--lr", type=float, default=1e-3, help="Adam learning rate (paper: 1e-3)")
    ap.add_argument("--max-iter", type=int, default=5000, help="L-BFGS iteration cap")
    ap.add_argument("--inner", type=int, default=50,
                    help="L-BFGS iterations between refreshes of the held motor parameters of F_U")
    ap.add_argument("--fu", choices=["held", "live"], default="held",
                    help="F_U with theta held (no gradient; liftwatch) or live (paper-literal)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--w-u", type=float, default=1.0)
    ap.add_argument("--w-f", type=float, default=1.0)
    ap.add_argument("--w-p", type=float, default=1.0)
    ap.add_argument("--w-n", type=float, default=0.2)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--infer", metavar="MODEL",
                    help="time batched inference of this liftwatch model on --input instead of fitting")
    ap.add_argument("--repeats", type=int, default=21, help="timed inference passes (--infer)")
    args = ap.parse_args()

    import torch
    torch.set_num_threads(args.threads)
    torch.set_default_dtype(torch.float64)
    if args.infer:
        return infer(args, torch)

    cpu0, wall0 = time.process_time(), time.perf_counter()
    e = read_elevator(args.elevator)
    mu, sd = prior(e)
    d = read_aligned(args.input)
    p_plat = fit_platform_ratio(d, e)
    f = features(d, e, p_plat)
    obs_np, n_moving, drive_off = observations(f, e, mu[NAMES.index("ke")])
    o = {k: torch.tensor(np.asarray(v, dtype=np.float64)) for k, v in obs_np.items()}
    # Fixed noise scales (liftwatch re-estimates them from its stage-1 residuals): the voltage
    # noise of its interpolation weights, and that noise mapped into newtons by the prior Kd.
    sigma_u = INTERPOLATION_NOISE_SHARE * e["u_r"]
    sigma_f = sigma_u / mu[NAMES.index("kd")]
    model = Hybrid(torch, e, mu, sd, sigma_u, sigma_f, args.seed)
    prep_wall = time.perf_counter() - wall0
    ws = (args.w_u, args.w_f, args.w_p, args.w_n)

    def ref():
        return None if args.fu == "live" else model.theta().detach()

    t_fit0, c_fit0 = time.perf_counter(), time.process_time()
    iters = evals = 0
    if args.optimizer == "adam":
        opt = torch.optim.Adam(model.params(), lr=args.lr)
        for _ in range(args.epochs):
            opt.zero_grad()
            loss, _, _ = model.loss(o, *ws, motor_ref=ref())
            loss.backward()
            opt.step()
        iters = evals = args.epochs
    else:
        opt = torch.optim.LBFGS(model.params(), lr=1.0, max_iter=args.inner,
                                history_size=30, line_search_fn="strong_wolfe",
                                tolerance_grad=1e-7, tolerance_change=1e-9)
        motor = [ref()]

        def closure():
            opt.zero_grad()
            loss, _, _ = model.loss(o, *ws, motor_ref=motor[0])
            loss.backward()
            return loss

        while iters < args.max_iter:
            motor[0] = ref()
            opt.param_groups[0]["max_iter"] = min(args.inner, args.max_iter - iters)
            opt.step(closure)
            st = opt.state[opt._params[0]]
            done = st["n_iter"] - iters
            iters = st["n_iter"]
            evals = st["func_evals"]
            # Converged when an inner run stops early and the held motor parameters have settled.
            moved = 0.0 if motor[0] is None else float(
                ((model.theta().detach() - motor[0]).abs() / model.sd).max())
            if done < opt.param_groups[0]["max_iter"] and moved < 1e-6:
                break
    fit_wall = time.perf_counter() - t_fit0
    fit_cpu = time.process_time() - c_fit0

    with torch.no_grad():
        loss, _, _ = model.loss(o, *ws, motor_ref=ref())
    model.set_box(o)
    train_rms, _ = rms_u(model, torch, f, hold=False)
    train_w, _ = rms_u(model, torch, f, hold=False, w=interpolation_weights(f, e, mu[NAMES.index("ke")]))
    out = {
        "optimizer": args.optimizer,
        "fu": args.fu,
        "fit_wall_s": round(fit_wall, 3),
        "fit_cpu_s": round(fit_cpu, 3),
        "prep_wall_s": round(prep_wall, 3),
        "process_cpu_s": None,
        "iterations": iters,
        "function_evals": evals,
        "loss": float(loss),
        "train_rms_u_v": round(train_rms, 4),
        "train_rms_u_v_weighted": round(train_w, 4),
        "moving_samples": n_moving,
        "observations": int(o["w"].numel()),
        "drive_off_at_rest": drive_off,
        "load_cell_p": round(p_plat, 4),
        "sigma_u_v": sigma_u,
        "sigma_f_n": round(sigma_f, 2),
        "test": {},
        "parameters": {n: float(x) for n, x in zip(NAMES, model.theta().detach().numpy())},
    }
    for tdir in args.test:
        dt = read_aligned(os.path.join(tdir, "aligned.csv"))
        ft = features(dt, e, p_plat)
        raw, n = rms_u(model, torch, ft, hold=False)
        held, _ = rms_u(model, torch, ft, hold=True)
        wtd, _ = rms_u(model, torch, ft, hold=False,
                       w=interpolation_weights(ft, e, mu[NAMES.index("ke")]))
        out["test"][tdir] = {"rms_u_v": round(raw, 4), "rms_u_v_held_box": round(held, 4),
                             "rms_u_v_weighted": round(wtd, 4), "moving_samples": n}
    r = os.times()
    out["process_cpu_s"] = round(r.user + r.system, 3)
    print(json.dumps(out))


if __name__ == "__main__":
    sys.exit(main())
