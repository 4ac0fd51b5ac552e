#!/usr/bin/env python3
"""liftwatch's fit beside the PyTorch reference (bench/pytorch_reference.py), interleaved.

In a fresh temporary directory: simulates the paper's setting (3 h from 07:00 at 1 Hz, seed 3)
as training and two held-out sets, then runs N rounds of
  1. liftwatch fit (end to end: features, physics, network, standard errors, risk calibration)
  2. the PyTorch reference with L-BFGS
  3. the PyTorch reference with the paper's Adam schedule
each process on one thread (taskset -c CPU when available, OMP_NUM_THREADS=1), and prints the
medians. Held-out sets:
  seed4   `simulate --seed 4`: same elevator.toml, but the simulator draws another plant
          (other true Kd, M0, friction ...) from the seed: a different machine
  later   the same machine (seed 3), the 3 hours after the training (10:00-13:00)
Held-out RMS of r_U over moving samples: liftwatch's from `monitor`'s per-second rows (rows with
an r_force, i.e. moving), PyTorch's from its own features. Also given weighted by liftwatch's
interpolation weights (same weights for both, from the reference's features).

Usage: LIFTWATCH=target/release/liftwatch python3 bench/compare.py [--runs 3] [--epochs 20000]

With --infer it compares the monitor's step with PyTorch's batched inference instead
(infer_main, bench/README.md).
"""

import argparse
import csv
import json
import math
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)
sys.path.insert(0, HERE)
sys.dont_write_bytecode = True  # no __pycache__ in bench/ from importing the reference


def run(cmd, pin, cwd):
    env = dict(os.environ, OMP_NUM_THREADS="1", MKL_NUM_THREADS="1", RAYON_NUM_THREADS="1")
    if pin is not None and shutil.which("taskset"):
        cmd = ["taskset", "-c", str(pin)] + cmd
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    p = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    if p.returncode != 0:
        sys.exit(f"failed ({p.returncode}): {' '.join(cmd)}\n{p.stderr}")
    cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    return p.stdout, wall, cpu


def lw_heldout(lw, model, tdir, work, weights):
    rows = os.path.join(work, "rows.csv")
    run([lw, "monitor", "--model", model, "--input", os.path.join(tdir, "aligned.csv"),
         "--out", rows], None, work)
    r2 = []
    num = den = 0.0
    with open(rows, newline="") as f:
        for x in csv.DictReader(f):
            if x["r_force"] == "" or x["r_voltage"] == "":
                continue  # r_F applies while moving only: these are the moving samples
            r = float(x["r_voltage"])
            r2.append(r * r)
            w = weights.get(round(float(x["time"]), 3))
            if w is not None:
                num += w * r * r
                den += w
    return math.sqrt(sum(r2) / len(r2)), math.sqrt(num / den) if den else float("nan"), len(r2)


def interpolation_weights(tdir, elevator):
    """time -> liftwatch's interpolation weight of each moving sample (reference's features;
    the weights do not depend on the load cell's p)."""
    import pytorch_reference as ref
    e = ref.read_elevator(elevator)
    mu, _ = ref.prior(e)
    d = ref.read_aligned(os.path.join(tdir, "aligned.csv"))
    f = ref.features(d, e, 0.25)
    w = ref.interpolation_weights(f, e, mu[ref.NAMES.index("ke")])
    return {round(float(t), 3): float(x) for t, x, s in zip(f["t"], w, f["s"]) if s != 0}


def infer_main(args, lw):
    """The monitor's step beside PyTorch's batched inference on the same samples and model:
    3 simulated days of a 1000 kg, 1.75 m/s, 26-floor car (seed 7) fitted by liftwatch, then
    2 other days (seed 1) monitored, the monitor bench's setting. liftwatch: the whole
    in-memory step of `cargo bench --bench monitor` (features, residuals, trip evidence, risk,
    levels, sensor and operation checks; one sample at a time, as it streams). PyTorch: the
    network, physics and residuals over all samples at once, float32 and float64."""
    ref = os.path.join(HERE, "pytorch_reference.py")
    work = tempfile.mkdtemp(prefix="liftwatch-infer-")
    car = ["--rated-load", "1000", "--rated-speed", "1.75", "--floors", "26"]
    run([lw, "simulate", "--days", "3", "--seed", "7", "--out", "train", "-q"] + car, None, work)
    run([lw, "simulate", "--days", "2", "--seed", "1", "--out", "mon", "-q"] + car, None, work)
    run([lw, "fit", "--input", "train/aligned.csv", "--elevator", "train/elevator.toml",
         "--out", "model.json", "-q"], None, work)
    env = dict(os.environ, MONITOR_BENCH_MODEL=os.path.join(work, "model.json"),
               MONITOR_BENCH_INPUT=os.path.join(work, "mon/aligned.csv"))
    cargo = ["cargo", "bench", "-q", "-p", "liftwatch", "--bench", "monitor"]
    p = subprocess.run(cargo + ["--no-run"], cwd=REPO, env=env, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"cargo bench --no-run failed:\n{p.stderr}")
    res = {"liftwatch": [], "float32": [], "float64": [], "float32 net": [], "float64 net": []}
    for k in range(args.runs):
        cmd = cargo if not shutil.which("taskset") else ["taskset", "-c", str(args.cpu)] + cargo
        p = subprocess.run(cmd, cwd=REPO, env=dict(env, OMP_NUM_THREADS="1"),
                           capture_output=True, text=True)
        line = [x for x in p.stdout.splitlines() if x.startswith("monitor step on file")]
        if p.returncode != 0 or not line:
            sys.exit(f"the monitor bench failed:\n{p.stdout}{p.stderr}")
        res["liftwatch"].append(float(line[0].split(": ")[1].split(" M")[0]) * 1e6)
        out, _, _ = run([args.python, ref, "--infer", "model.json", "--input", "mon/aligned.csv",
                         "--elevator", "mon/elevator.toml"], args.cpu, work)
        j = json.loads(out.strip().splitlines()[-1])
        for dt in ("float32", "float64"):
            res[dt].append(j[dt]["samples_per_s"])
            res[dt + " net"].append(j[dt]["network_only_samples_per_s"])
        print(f"round {k + 1}/{args.runs} done", file=sys.stderr, flush=True)
    med = {k: statistics.median(v) for k, v in res.items()}
    lw_rms, _, _ = lw_heldout(lw, "model.json", "mon", work, {})
    print(f"\nmedians of {args.runs} interleaved rounds, one thread each, pinned to CPU "
          f"{args.cpu}; {j['samples']} samples, {j['moving']} moving; RMS r_U over moving "
          f"samples (the same model on the same samples): liftwatch {lw_rms:.3f} V, PyTorch "
          f"{j['float64']['rms_u_v_moving']:.3f} V")
    print("| | M samples/s | liftwatch's step / this |")
    print("|---|---|---|")
    names = {"liftwatch": "liftwatch, whole monitor step (streaming, one sample at a time)",
             "float32": "PyTorch float32, network + physics + residuals (batched)",
             "float64": "PyTorch float64, network + physics + residuals (batched)",
             "float32 net": "PyTorch float32, network alone (batched)",
             "float64 net": "PyTorch float64, network alone (batched)"}
    for k, name in names.items():
        print(f"| {name} | {med[k] / 1e6:.2f} | {med['liftwatch'] / med[k]:.2f}x |")
    if args.keep:
        print(f"kept {work}")
    else:
        shutil.rmtree(work)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--epochs", type=int, default=20000, help="Adam epochs (paper: 20,000)")
    ap.add_argument("--adam-runs", type=int, default=None,
                    help="rounds that include Adam (default: all)")
    ap.add_argument("--max-iter", type=int, default=5000, help="PyTorch L-BFGS iteration cap")
    ap.add_argument("--cpu", type=int, default=1, help="core to pin every process to")
    ap.add_argument("--python", default=sys.executable)
    ap.add_argument("--keep", action="store_true", help="keep the temporary directory")
    ap.add_argument("--json", action="store_true", help="also print every run as JSON lines")
    ap.add_argument("--infer", action="store_true",
                    help="the monitor's step beside PyTorch's batched inference instead of the fit")
    args = ap.parse_args()
    lw = os.path.abspath(os.environ.get("LIFTWATCH", os.path.join(REPO, "target/release/liftwatch")))
    if not os.path.exists(lw):
        sys.exit(f"no liftwatch binary at {lw}: build it (cargo build --release) or set LIFTWATCH")
    if args.infer:
        return infer_main(args, lw)
    adam_runs = args.runs if args.adam_runs is None else args.adam_runs
    ref = os.path.join(HERE, "pytorch_reference.py")
    work = tempfile.mkdtemp(prefix="liftwatch-bench-")
    sim = lambda seed, days, out: run([lw, "simulate", "--days", days, "--start-hour", "7",
                                       "--seed", seed, "--out", out], None, work)
    sim("3", "0.125", "train")
    sim("4", "0.125", "seed4")
    sim("3", "0.25", "long")
    os.makedirs(os.path.join(work, "later"))
    with open(os.path.join(work, "long/aligned.csv")) as f, \
            open(os.path.join(work, "later/aligned.csv"), "w") as g:
        lines = f.readlines()
        g.write(lines[0])
        g.writelines(lines[1 + 10800:])  # the rows after the training's 3 hours
    shutil.copy(os.path.join(work, "long/elevator.toml"), os.path.join(work, "later"))
    tests = ["seed4", "later"]
    elevator = os.path.join(work, "train/elevator.toml")
    weights = {t: interpolation_weights(os.path.join(work, t), elevator)
               for t in tests + ["train"]}

    load_before = os.getloadavg()
    res = {"liftwatch": [], "torch-lbfgs": [], "torch-adam": []}
    for k in range(args.runs):
        # liftwatch, end to end
        _, wall, cpu = run([lw, "fit", "--input", "train/aligned.csv", "--elevator",
                            "train/elevator.toml", "--out", "m.json", "-q"], args.cpu, work)
        with open(os.path.join(work, "m.json")) as f:
            m = json.load(f)
        params, lw_iters = m["parameters"], m["fit"]["iterations"]
        tr = lw_heldout(lw, "m.json", "train", work, weights["train"])
        r = {"wall": wall, "cpu": cpu, "iters": lw_iters, "train": tr[0], "params": params}
        for t in tests:
            raw, wtd, n = lw_heldout(lw, "m.json", t, work, weights[t])
            r[t], r[t + "_w"] = raw, wtd
        res["liftwatch"].append(r)
        kinds = [("torch-lbfgs", ["--optimizer", "lbfgs", "--max-iter", str(args.max_iter)])]
        if k < adam_runs:
            kinds.append(("torch-adam", ["--optimizer", "adam", "--epochs", str(args.epochs)]))
        for name, extra in kinds:
            cmd = [args.python, ref, "--input", "train/aligned.csv", "--elevator",
                   "train/elevator.toml"] + sum([["--test", t] for t in tests], []) + extra
            out, wall, cpu = run(cmd, args.cpu, work)
            j = json.loads(out.strip().splitlines()[-1])
            r = {"wall": wall, "cpu": cpu, "fit_wall": j["fit_wall_s"], "iters": j["iterations"],
                 "train": j["train_rms_u_v"], "params": j["parameters"]}
            for t in tests:
                r[t] = j["test"][t]["rms_u_v"]
                r[t + "_w"] = j["test"][t]["rms_u_v_weighted"]
            res[name].append(r)
        if args.json:
            for name in res:
                if len(res[name]) > k:
                    print(json.dumps({"run": k, "kind": name, **res[name][k]}), flush=True)
        print(f"round {k + 1}/{args.runs} done", file=sys.stderr, flush=True)

    med = lambda name, key: statistics.median(r[key] for r in res[name]) if res[name] else math.nan
    print(f"\nmedians of {args.runs} interleaved rounds (Adam: {adam_runs}), one thread each, "
          f"pinned to CPU {args.cpu}; load average before "
          f"{load_before[0]:.2f}, after {os.getloadavg()[0]:.2f} ({os.cpu_count()} CPUs)")
    hdr = ("", "wall s", "CPU s", "fit-only s", "iters", "train r_U", "seed4 r_U", "later r_U",
           "seed4 w", "later w")
    print("| " + " | ".join(hdr) + " |")
    print("|" + "---|" * len(hdr))
    for name in res:
        if not res[name]:
            continue
        fo = f"{med(name, 'fit_wall'):.2f}" if name != "liftwatch" else "-"
        it = f"{med(name, 'iters'):.0f}" + (" (stage 2)" if name == "liftwatch" else "")
        print(f"| {name} | {med(name, 'wall'):.2f} | {med(name, 'cpu'):.2f} | {fo} | {it} | "
              f"{med(name, 'train'):.3f} | {med(name, 'seed4'):.3f} | {med(name, 'later'):.3f} | "
              f"{med(name, 'seed4_w'):.3f} | {med(name, 'later_w'):.3f} |")
    base_w, base_c = med("liftwatch", "wall"), med("liftwatch", "cpu")
    for name in ("torch-lbfgs", "torch-adam"):
        if res[name]:
            print(f"{name}/liftwatch: wall x{med(name, 'wall') / base_w:.1f}, "
                  f"CPU x{med(name, 'cpu') / base_c:.1f}, fit-only wall x"
                  f"{med(name, 'fit_wall') / base_w:.1f}")
    print("r_U columns: RMS (V) over moving samples; 'w': weighted by liftwatch's interpolation "
          "weights; seed4 = another simulated machine, later = same machine, next 3 hours")
    for name in res:
        if res[name]:
            print(f"{name} parameters (last run): " + ", ".join(
                f"{k}={v:.5g}" for k, v in res[name][-1]["params"].items()))
    if args.keep:
        print(f"kept {work}")
    else:
        shutil.rmtree(work)


if __name__ == "__main__":
    main()
