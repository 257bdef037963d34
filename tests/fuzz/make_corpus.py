#!/usr/bin/env python3
"""tests/fuzz/make_corpus.py: writes the seed corpora of the libFuzzer targets (issue 7).

  python3 tests/fuzz/make_corpus.py OUT_DIR

OUT_DIR/correction_request/  request bodies: the examples of clients/examples (a complete,
                             valid correction request and its variants with options and teeth)
                             and every POST body of the hostile corpus tests/server/data/
                             hostile_requests.jsonl (broken JSON, wrong types and shapes, NaN
                             spelt many ways, impossible gears, deep nests, ...)
OUT_DIR/csv_grid/            CSV grids: clients/examples/measurement.csv and the good and bad
                             files of tests/clients/data, each behind the two option bytes of
                             csv_grid_fuzzer.cc (5 x 9, missing points allowed or not)
OUT_DIR/mka/                 Klingelnberg curve files: the sample of tests/formats/data, with LF
                             and without byte-order mark, in Latin-1, as plain Profil: blocks,
                             truncated, and with a huge value count
OUT_DIR/split_bevel_request/ split-trajectory request bodies: the wheel of docs/split-bevel.md,
                             with every optional field, a pinion to a chord tolerance, and
                             refusals (both of a pair, a tool too wide, out-of-limit axes)
OUT_DIR/gde/                 GDE XML: the sample, a measured/target/predicted export layout, and
                             a few broken ones (truncated, decimal comma, duplicate point)

The seeds are generated rather than kept as copies so that they follow the test data; the fuzzers
add what they find to OUT_DIR (keep it in a build directory).
"""
import glob
import hashlib
import json
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
MAX_SEED_BYTES = 64 * 1024


def write(directory, data):
    if isinstance(data, str):
        data = data.encode("utf-8", "surrogateescape")
    if len(data) > MAX_SEED_BYTES:
        return 0
    name = hashlib.sha1(data).hexdigest()
    with open(os.path.join(directory, name), "wb") as f:
        f.write(data)
    return 1


def write_measurement_files(out):
    mka_dir = os.path.join(out, "mka")
    gde_dir = os.path.join(out, "gde")
    os.makedirs(mka_dir, exist_ok=True)
    os.makedirs(gde_dir, exist_ok=True)
    data = os.path.join(ROOT, "tests/formats/data")
    with open(os.path.join(data, "sample_topography.mka"), "rb") as f:
        mka = f.read()
    with open(os.path.join(data, "sample_topography.gde.xml"), "rb") as f:
        gde = f.read()
    n = 0
    lf = mka[3:].replace(b"\r\n", b"\n")
    n += write(mka_dir, mka)
    n += write(mka_dir, lf)
    n += write(mka_dir, lf.decode("utf-8").encode("latin-1", "replace"))
    n += write(mka_dir, mka[: len(mka) // 3])
    n += write(mka_dir, mka.replace(b"48 Werte", b"99999999 Werte", 1))
    head = lf[: lf.index(b"TOPOGRAFIE:")]
    n += write(mka_dir, head + b"Profil:\nZahn-Nr.: 1 rechts / 4 Werte\n 1.0 2.0 3.0 4.0\n"
                             b"Flankenlinie:\nZahn-Nr.: 1 rechts / 3 Werte\n 0.5 0.25 0.0\nTeilung:\n 1 2 3\n")
    n += write(gde_dir, gde)
    n += write(gde_dir, gde[: len(gde) // 2])
    n += write(gde_dir, gde.replace(b'dev="-3.999"', b'dev="-3,999"'))
    n += write(gde_dir, gde.replace(b'z="5.600" dev="-12.939"', b'z="2.000" dev="-12.939"'))
    n += write(gde_dir, gde.replace(b"<TOPOGRAPHY tooth", b'<TOPOGRAPHY kind="target" tooth', 1)
               .replace(b"</MEASUREMENT_RESULTS>", gde[gde.index(b"<TOPOGRAPHY"):gde.index(b"</MEASUREMENT_RESULTS>")]
                        + b"</MEASUREMENT_RESULTS>"))
    return n


def write_split_bevel_requests(out):
    directory = os.path.join(out, "split_bevel_request")
    os.makedirs(directory, exist_ok=True)
    wheel = {"gear": {"teeth": 75, "pitch_angle_deg": 70, "outer_transverse_module_mm": 40,
                      "face_width_mm": 240, "mean_spiral_angle_deg": 35, "hand": "right",
                      "pressure_angle_deg": 20},
             "tool": {"radius_mm": 8, "stock_mm": 0.2},
             "cut": {"slot_index": 3, "flanks": ["convex", "concave"], "depth_levels": 4, "steps": 5},
             "machine": {"pivot_length_mm": 300}, "output": {"nc": True}}
    full = json.loads(json.dumps(wheel))
    full["gear"].update({"addendum_mm": 28, "dedendum_mm": 36, "slot_width_mm": 45})
    full["cut"].update({"from": "heel", "feed_mm_per_min": 150})
    full["machine"].update({"a_limits_deg": [-110, 110], "b_limits_deg": [-200, 200]})
    full["setup"] = {"apex_mm": [10, -5, 600], "segment_mid_deg": 14, "segment_angle_deg": 30}
    pinion = {"gear": {"teeth": 19, "pitch_angle_deg": 20, "outer_cone_distance_mm": 877,
                       "face_width_mm": 120, "outer_spiral_angle_deg": 38, "hand": "left",
                       "pressure_angle_deg": 20},
              "tool": {"radius_mm": 6}, "cut": {"depth_levels": 1, "chord_tolerance_mm": 0.05}}
    bodies = [wheel, full, pinion]
    for edit in ({"tool": {"radius_mm": 30}}, {"machine": {"a_limits_deg": [-5, 5]}},
                 {"cut": {"steps": 5, "chord_tolerance_mm": 0.01}}):
        bodies.append(dict(wheel, **edit))
    both = json.loads(json.dumps(wheel))
    both["gear"]["outer_cone_distance_mm"] = 1600
    bodies.append(both)
    return sum(write(directory, json.dumps(b)) for b in bodies)


def main():
    if len(sys.argv) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    out = sys.argv[1]
    requests = os.path.join(out, "correction_request")
    grids = os.path.join(out, "csv_grid")
    os.makedirs(requests, exist_ok=True)
    os.makedirs(grids, exist_ok=True)

    with open(os.path.join(ROOT, "clients/examples/request.json")) as f:
        request = json.load(f)
    with open(os.path.join(ROOT, "clients/examples/measurement.json")) as f:
        measurement = json.load(f)["deviations_um"]
    n_requests = 0
    valid = dict(request, measurement={"deviations_um": measurement})
    n_requests += write(requests, json.dumps(valid))
    # The job's trace and tolerance (issue 16).
    n_requests += write(requests, json.dumps(dict(valid, trace={
        "part_number": "4711-A", "serial": "S1", "teeth": [1, 10], "measured_at": "2026-11-22T07:45:00+01:00",
        "file_name": "S1.mka", "machine_id": "RZ260-2"}, tolerance={"rms_um": 1.5, "max_um": 4, "iso_class": 6})))
    n_requests += write(requests, json.dumps(dict(valid, options={
        "solver": "pso", "mode": "rework", "max_order": {"A": 1}, "probe_noise_um": 0.3,
        "pso_particles": 10, "pso_generations": 20, "point_weights": [[1] * 9] * 5})))
    n_requests += write(requests, json.dumps(dict(valid, measurement={"teeth": [measurement, measurement]},
                                                  target={"deviations_um": measurement})))
    n_requests += write(requests, json.dumps(dict(request, settings={"axes": {"X": [0, 0.1], "C": [0, 0, 1e-4]},
                                                                     "wheel": {"cone_angle_deg": 0.01}})))
    # Measuring-machine files in a request (issue 15): an import body and a correction with one.
    with open(os.path.join(ROOT, "tests/formats/data/sample_topography.mka"), encoding="utf-8-sig") as f:
        mka = f.read()
    file = {"format": "mka", "content": mka[:2000], "tooth": 1, "datum_face": "x_negative",
            "sign_factors": {"helix_right": -1}}
    n_requests += write(requests, json.dumps(dict(file, gear=request["gear"], flank="left")))
    n_requests += write(requests, json.dumps(dict(request, measurement={"file": file})))
    # The plunge-shaving cutter target (issue 18): its own body, and as a correction's target,
    # resolved (with the stock_target_um the server stores) or not.
    with open(os.path.join(ROOT, "clients/examples/shaving.json")) as f:
        shaving = json.load(f)
    n_requests += write(requests, json.dumps(shaving))
    n_requests += write(requests, json.dumps(dict(valid, target={"shaving": shaving})))
    stored = [[None] * 9] + [[-1.5] * 9] * 4
    n_requests += write(requests, json.dumps(dict(valid, target={"shaving": shaving, "stock_target_um": stored})))
    with open(os.path.join(ROOT, "tests/server/data/hostile_requests.jsonl")) as f:
        for line in f:
            case = json.loads(line)
            if case["method"] == "POST" and case.get("body"):
                n_requests += write(requests, case["body"])

    n_grids = 0
    csv_files = [os.path.join(ROOT, "clients/examples/measurement.csv")] + sorted(
        glob.glob(os.path.join(ROOT, "tests/clients/data/*.csv")))
    for path in csv_files:
        with open(path, "rb") as f:
            text = f.read()
        n_grids += write(grids, b"\x0c\x08" + text)  # 5 x 9, missing points allowed
        n_grids += write(grids, b"\x04\x08" + text)  # 5 x 9, complete (a target grid)
    n_files = write_measurement_files(out)
    n_split = write_split_bevel_requests(out)
    print(f"make_corpus: {n_requests} request seeds in {requests}, {n_grids} grid seeds in {grids}, "
          f"{n_files} measurement-file seeds in {out}/mka and {out}/gde, "
          f"{n_split} split-trajectory seeds in {out}/split_bevel_request")
    return 0


if __name__ == "__main__":
    sys.exit(main())
