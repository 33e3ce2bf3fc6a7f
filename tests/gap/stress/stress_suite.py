"""The gap diagnosis's independent stress suite (issue 17): for every case of generate_trials.py and
every seed, synthetic eKnee CSVs of JW's three trials are written by the independent generator and
diagnosed by `kneesim gap` exactly as a user would run share/gap/jw_gap.xml (its trials, its
settings, target total); the verdicts are scored against what was injected and the whole matrix is
printed, failures included.

    python3 stress_suite.py --kneesim build/bin/kneesim [--seeds 20] [--cases a,b] [--jobs 2]
                            [--work DIR] [--matrix FILE] [--check]

--check exits non-zero unless the issue's demands hold: outside effects whose remaining systematic
error (the selected model's withheld prediction against the noise-free truth) exceeds the noise get
"none of the candidates" or "partly explained" in >= 90 % of those seeds; in-catalogue effects at 2x
the noise are named in >= 90 %; nothing injected gives "baseline" in >= 90 %.
"""

import argparse
import concurrent.futures
import json
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import generate_trials as G  # noqa: E402
import jw_inputs as J  # noqa: E402

ROOT = os.path.abspath(os.path.join(HERE, "../../.."))
CLASSES = ("explained", "partly explained", "not explained", "undecided", "baseline")


def write_setup(template, out_dir, csv_dir, areas, data):
    """The template GapTool setup with its trials' knee forces replaced by the synthetic CSVs and their
    areas pointed at @p areas; everything else (C3D files, settings) as the template says."""
    # Comments dropped first: the setup's comments quote command lines ("--trials"), which XML's
    # comment rule forbids and expat refuses (kneesim's reader accepts them).
    text = re.sub(r"<!--.*?-->", "", open(template).read(), flags=re.S)
    root = ET.fromstring(text)
    tree = ET.ElementTree(root)
    tdir = os.path.dirname(os.path.abspath(template))
    for tag in ("workflow_results", "results_directory"):
        for e in root.findall(tag):
            root.remove(e)
    for tag, value in (("bootstrap_samples", "0"), ("plots", "false"), ("targets", "total")):
        e = root.find(tag)
        if e is None:
            e = ET.SubElement(root, tag)
        e.text = value
    for trial in root.iter("Trial"):
        name = trial.get("name")
        trial.find("knee_forces").text = os.path.join(csv_dir, "jw_%s_knee_forces.csv" % name)
        c3d = trial.find("c3d")
        if c3d is not None:
            c3d.text = os.path.normpath(os.path.join(tdir, c3d.text))
        ca = trial.find("contact_area")
        if ca is None:
            ca = ET.SubElement(trial, "contact_area")
        ca.text = os.path.join(areas, "jw_%s_contact_area.sto" % name)
        # The knee's net loads where inverse dynamics has them (the workflow's <trial>_knee_loads.sto,
        # as `kneesim gap --workflow-results` reads them): the knee_load effect's channels.
        loads = os.path.join(areas, "jw_%s_knee_loads.sto" % name)
        if os.path.exists(loads) and trial.find("knee_loads") is None:
            ET.SubElement(trial, "knee_loads").text = loads
    path = os.path.join(out_dir, "setup.xml")
    tree.write(path)
    return path


def read_series(path):
    """total_series.dat: per trial block, rows (time, measured, baseline, selected)."""
    blocks, cur = [], None
    for line in open(path):
        if line.startswith("# per trial"):
            continue
        if line.startswith("# "):
            cur = []
            blocks.append(cur)
            continue
        p = line.split()
        if len(p) >= 4 and cur is not None:
            cur.append(tuple(float(x) for x in p[:4]))
    return blocks


def classify(target):
    """The verdict's class; reports without verdict_class (before issue 17) are read by their verdict."""
    if "verdict_class" in target:
        return target["verdict_class"]
    v = target["verdict"]
    if v == "baseline":
        return "baseline"
    if v == "none of the candidates":
        return "partly explained" if target.get("selected") else "not explained"
    return "explained"


def run_one(kneesim, sources, k, case, seed, work, areas, data, template):
    d = os.path.join(work, case["name"], "seed%02d" % seed)
    shutil.rmtree(d, ignore_errors=True)
    os.makedirs(d)
    G.write_trials(sources, k, case, seed, d)
    if "setup" in case:  # a case diagnosed on another of share/gap's setups
        template = os.path.join(ROOT, "share/gap", case["setup"])
    setup = write_setup(template, d, d, areas, data)
    res = os.path.join(d, "result")
    t0 = time.time()
    p = subprocess.run([kneesim, "-q", "gap", setup, "-o", res, "--targets", "total", "--no-plots"],
                       capture_output=True, text=True)
    seconds = time.time() - t0
    if p.returncode != 0:
        return {"case": case["name"], "seed": seed, "error": (p.stderr or p.stdout).strip()[-400:]}
    rep = json.load(open(os.path.join(res, "gap_report.json")))
    t = rep["targets"][0]
    # Remaining systematic error: the selected model's withheld prediction against the noise-free truth.
    truth = {}
    for line in open(os.path.join(d, "truth.csv")).read().splitlines()[1:]:
        trial, tt, f, _ = line.split(",")
        truth.setdefault(trial, ([], []))
        truth[trial][0].append(float(tt))
        truth[trial][1].append(float(f))
    diffs = []
    for name, block in zip(rep["trials"], read_series(os.path.join(res, "total_series.dat"))):
        tt, ff = truth[name]
        for (time_s, _, _, sel) in block:
            if math.isfinite(sel):
                diffs.append(J.interp(tt, ff, time_s) - sel)
    rs = t.get("remaining_structure", {})
    nf = rs.get("noise_floor", {})
    ag = rs.get("model_agnostic_check", {})
    out = {
        "case": case["name"], "seed": seed, "class": classify(t), "verdict": t["verdict"],
        "selected": t.get("selected", []), "remaining_systematic": J.rms(diffs),
        "rmse_baseline": t["baseline_heldout_rmse_N"], "seconds": seconds,
        "rmse_selected": t["shrinkage"][0]["rmse_final_N"] if t.get("shrinkage") else float("nan"),
        "noise_floor": nf.get("floor_N") if nf.get("floor_N") is not None else float("nan"),
        "agnostic": bool(ag.get("significant", False)), "evidence": rs.get("evidence", []),
        "floor_consistent": bool(nf.get("consistent", False)), "floor_above": bool(nf.get("above", False)),
        "excess_share": nf.get("excess_share"), "excess_share_upper": nf.get("excess_share_upper"),
        "floor_cycles_needed": nf.get("cycles_needed"),
        "wander_p": rs.get("recording_wander", {}).get("p_value"), "mean_gap_p": rs.get("p_value"),
        "carriers": [i["signal"] for i in ag.get("importance", [])[:3]] if ag.get("significant") else [],
    }
    shutil.rmtree(d, ignore_errors=True)
    return out


def is_right(case, o):
    """Whether an outcome is what the case demands (None: the case demands nothing of this seed)."""
    exp = case["expect"]
    if exp == "baseline":
        return o["class"] == "baseline"
    if exp == "outside":
        if not o["remaining_systematic"] > G.NOISE_SD:
            return None
        return o["class"] in ("not explained", "partly explained")
    return exp in o["selected"] and o["class"] in ("explained", "partly explained")


def wilson(k, n, z=1.959964):
    if n == 0:
        return float("nan"), float("nan")
    p = k / n
    c = (p + z * z / (2 * n)) / (1 + z * z / n)
    h = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return c - h, c + h


def median(v):
    v = sorted(x for x in v if isinstance(x, float) and math.isfinite(x))
    if not v:
        return float("nan")
    m = len(v) // 2
    return v[m] if len(v) % 2 else 0.5 * (v[m - 1] + v[m])


def matrix(cases, outcomes):
    head = ("| case (size) | explained | partly explained | not explained | undecided | baseline | errors | "
            "named first (counts) | right [95 % interval] | remaining systematic > noise | median remaining "
            "systematic (N) | withheld RMSE baseline -> selected (N) | noise floor (N) |")
    lines = [head, "|" + "---|" * 13]
    demands = []
    for c in cases:
        outs = [o for o in outcomes if o["case"] == c["name"]]
        ok = [o for o in outs if "error" not in o]
        counts = {k: sum(1 for o in ok if o["class"] == k) for k in CLASSES}
        named = {}
        for o in ok:
            first = o["selected"][0] if o["selected"] else "-"
            named[first] = named.get(first, 0) + 1
        judged = [is_right(c, o) for o in ok]
        judged = [j for j in judged if j is not None]
        right = sum(judged)
        lo, hi = wilson(right, len(judged))
        above = sum(1 for o in ok if o["remaining_systematic"] > G.NOISE_SD)
        size = c.get("size")
        label = "%s (%s)%s" % (c["name"], ("%.4g" % size) if isinstance(size, float) else "-",
                               (" on " + c["setup"]) if "setup" in c else "")
        lines.append("| %s | %d | %d | %d | %d | %d | %d | %s | %s | %d/%d | %.0f | %.0f -> %.0f | %.0f |" % (
            label, counts["explained"], counts["partly explained"], counts["not explained"], counts["undecided"],
            counts["baseline"], len(outs) - len(ok),
            ", ".join("%s %d" % kv for kv in sorted(named.items(), key=lambda kv: -kv[1])),
            ("%d/%d [%.0f-%.0f %%]" % (right, len(judged), 100 * lo, 100 * hi)) if judged else "n/a",
            above, len(ok), median([o["remaining_systematic"] for o in ok]),
            median([o["rmse_baseline"] for o in ok]), median([o["rmse_selected"] for o in ok]),
            median([o["noise_floor"] for o in ok])))
        demanded = c["expect"] in ("baseline", "outside") or c.get("visible") == 2.0
        if demanded and judged:
            demands.append((c["name"], right, len(judged), right >= 0.9 * len(judged)))
        elif demanded:
            # Nothing to judge: every seed failed, or (outside effects) none left more than the noise.
            demands.append((c["name"], 0, 0, len(ok) == len(outs) and len(outs) > 0))
    return "\n".join(lines), demands


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--kneesim", required=True)
    ap.add_argument("--data", default=os.path.join(ROOT, "data"))
    ap.add_argument("--areas", default=os.path.join(ROOT, "tests/gap/fixtures"))
    ap.add_argument("--setup", default=os.path.join(ROOT, "share/gap/jw_gap.xml"))
    ap.add_argument("--cases", default="")
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--first-seed", type=int, default=1)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--work", default="")
    ap.add_argument("--matrix", default="")
    ap.add_argument("--outcomes", default="", help="write every outcome as JSON lines here")
    ap.add_argument("--check", action="store_true")
    a = ap.parse_args()
    for k in ("kneesim", "data", "areas", "setup"):
        setattr(a, k, os.path.abspath(getattr(a, k)))
    t0 = time.time()
    sources = G.load_sources(a.data, a.areas)
    k = G.fit_k(sources, [s["measured"] for s in sources])
    names = [n for n in a.cases.split(",") if n] or list(G.CASES)
    cases = [G.resolve_case(sources, k, n) for n in names]
    work = a.work or tempfile.mkdtemp(prefix="gap_stress_")
    # Seed-major: an interrupted matrix has every case at the seeds it reached.
    jobs = [(c, s) for s in range(a.first_seed, a.first_seed + a.seeds) for c in cases]
    outcomes = []
    # Each outcome is appended to --outcomes as it arrives, so an interrupted matrix keeps what it ran.
    sink = open(a.outcomes, "w") if a.outcomes else None
    with concurrent.futures.ThreadPoolExecutor(max_workers=a.jobs) as ex:
        futs = [ex.submit(run_one, a.kneesim, sources, k, c, s, work, a.areas, a.data, a.setup) for c, s in jobs]
        for f in concurrent.futures.as_completed(futs):
            o = f.result()
            outcomes.append(o)
            if sink:
                sink.write(json.dumps(o) + "\n")
                sink.flush()
            if "error" in o:
                print("[ error ] %s seed %d: %s" % (o["case"], o["seed"], o["error"]), flush=True)
    if sink:
        sink.close()
    outcomes.sort(key=lambda o: (names.index(o["case"]), o["seed"]))
    if not a.work:
        shutil.rmtree(work, ignore_errors=True)
    table, demands = matrix(cases, outcomes)
    elapsed = time.time() - t0
    text = ("Independent stress suite: Hertz (K = %.4g Pa fitted to JW's real forces) on JW's real contact areas, "
            "smooth noise %.0f N (correlation time %.0f ms), %d seed(s) per case, %d diagnoses in %.0f s "
            "(%d jobs)\n\n%s\n" % (k, G.NOISE_SD, 1000 * G.NOISE_TIME, a.seeds, len(outcomes), elapsed, a.jobs, table))
    for c in cases:
        if "visible_rms" in c:
            text += "\n%s: size %.4g (what the baseline cannot absorb: %.0f N RMS)" % (c["name"], c["size"], c["visible_rms"])
    print(text, flush=True)
    for o in outcomes:
        if "error" not in o:
            r = is_right(next(c for c in cases if c["name"] == o["case"]), o)
            if r is False:
                print("[ miss ] %s seed %d: %s (%s); remaining systematic %.0f N" % (
                    o["case"], o["seed"], o["class"], o["verdict"], o["remaining_systematic"]))
    if a.matrix:
        with open(a.matrix, "w") as f:
            f.write(text + "\n")
    failed = [d for d in demands if not d[3]]
    for name, right, n, ok in demands:
        print("[ %s ] %s: %d/%d right (demand >= 90 %%)" % ("ok" if ok else "FAIL", name, right, n))
    errors = [o for o in outcomes if "error" in o]
    if a.check and (failed or errors):
        sys.exit(1)


if __name__ == "__main__":
    main()
