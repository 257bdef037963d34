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
    n_requests += write(requests, json.dumps(dict(valid, options={
        "solver": "pso", "mode": "rework", "max_order": {"A": 1}, "probe_noise_um": 0.3,
        "pso_particles": 10, "pso_generations": 20, "point_weights": [[1] * 9] * 5})))
    n_requests += write(requests, json.dumps(dict(valid, measurement={"teeth": [measurement, measurement]},
                                                  target={"deviations_um": measurement})))
    n_requests += write(requests, json.dumps(dict(request, settings={"axes": {"X": [0, 0.1], "C": [0, 0, 1e-4]},
                                                                     "wheel": {"cone_angle_deg": 0.01}})))
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
    print(f"make_corpus: {n_requests} request seeds in {requests}, {n_grids} grid seeds in {grids}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
