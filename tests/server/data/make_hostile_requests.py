#!/usr/bin/env python3
"""Writes hostile_requests.jsonl: malformed and hostile requests for the server (issue 7).

One JSON object per line:
  {"name": ..., "method": "POST", "path": "/api/v1/corrections",
   "body": "<text>" or "body_b64": "<base64 of raw bytes>",
   "expect": 400 | 404 | 405 | 413 | 422 | "4xx"}
tests/server/hostile_requests_test.cc sends every line to a real server and checks the status
(never a 5xx), the error body, that the server stays up, and that no job was stored.

Regenerate with: python3 tests/server/data/make_hostile_requests.py > tests/server/data/hostile_requests.jsonl
"""
import base64
import copy
import json
import sys

GEAR = {"teeth": 37, "normal_module_mm": 6, "normal_pressure_angle_deg": 20, "helix_angle_deg": 15,
        "hand": "left", "face_width_mm": 78, "tip_radius_mm": 120.9157, "root_radius_mm": 107.1569}
BASE = {"gear": GEAR, "wheel": {"radius_mm": 350},
        "machine": {"kind": "flat-wheel-grinder", "k1_mm": 0, "k2_mm": 0, "traverse_mm_per_rad": 0},
        "grid": {"profile_points": 5, "lead_points": 9, "profile_range": [0.2, 0.9], "lead_range": [-0.4, 0.4]},
        "flank": "right",
        "measurement": {"deviations_um": [[0.5] * 9 for _ in range(5)]}}
CORRECTIONS = "/api/v1/corrections"
cases = []


def add(name, body=None, expect="4xx", method="POST", path=CORRECTIONS, raw=None):
    case = {"name": name, "method": method, "path": path, "expect": expect}
    if raw is not None:
        case["body_b64"] = base64.b64encode(raw).decode()
    else:
        case["body"] = body if isinstance(body, str) else json.dumps(body)
    cases.append(case)


def edited(path, value, delete=False):
    request = copy.deepcopy(BASE)
    node = request
    for key in path[:-1]:
        node = node[key]
    if delete:
        del node[path[-1]]
    else:
        node[path[-1]] = value
    return request


# 1. Broken JSON.
for i, text in enumerate(["", " ", "{", "}", "{\"gear\":", "{\"gear\": {}", "{'gear': 1}", "{gear: 1}",
                          "{\"gear\": 1,}", "[1, 2,]", "{\"a\": 1} trailing", "// comment\n{}", "{\"a\": /*c*/ 1}",
                          "{\"a\": \"unterminated}", "{\"a\": \"\\x41\"}", "{\"a\": \"\\u12\"}", "{\"a\": 01}",
                          "{\"a\": .5}", "{\"a\": 1.}", "{\"a\": +1}", "{\"a\": 0x10}", "{\"a\": TRUE}",
                          "{\"a\": undefined}", "\ufeff{}", "{\"a\":\"tab\there\"}", "{\"a\" 1}", "{,}", "{\"\":}"]):
    add(f"broken json {i}: {text[:20]!r}", text, 400)
for text in ["null", "true", "42", "\"gear\"", "[]", "[{}]"]:
    add(f"json but not an object: {text}", text, 400)

# 2. NaN and Infinity written in many ways.
for text in ["NaN", "nan", "-NaN", "Infinity", "-Infinity", "+Infinity", "inf", "-inf", "1e999", "-1e999",
             "1e400", "2e308"]:
    add(f"non-finite number {text} in gear.teeth", "{\"gear\": {\"teeth\": %s}}" % text, 400)
    add(f"non-finite number {text} in a measurement", json.dumps(BASE).replace("0.5", text, 1), 400)
for text in ["\"NaN\"", "\"Infinity\"", "\"1e999\""]:
    add(f"number as string {text} in wheel.radius_mm", json.dumps(edited(["wheel", "radius_mm"], 0)).replace(
        "\"radius_mm\": 0", "\"radius_mm\": %s" % text), 400)

# 3. Wrong types, field by field (400 naming the field).
wrong_types = {"string": "x", "null": None, "array": [1], "object": {"v": 1}, "bool": True}
numeric_fields = [["gear", k] for k in GEAR if k != "hand"] + [["wheel", "radius_mm"]] + \
                 [["machine", k] for k in ("k1_mm", "k2_mm", "traverse_mm_per_rad")] + \
                 [["grid", "profile_points"], ["grid", "lead_points"]]
for field in numeric_fields:
    for type_name, value in wrong_types.items():
        add(f"{'.'.join(field)} as {type_name}", edited(field, value), 400)
for field in (["gear", "hand"], ["flank"], ["machine", "kind"]):
    for type_name, value in (("number", 7), ("array", ["left"]), ("object", {})):
        add(f"{'.'.join(field)} as {type_name}", edited(field, value), 400)
for part in ("gear", "wheel", "measurement"):
    add(f"missing {part}", edited([part], None, delete=True), 400)
    add(f"{part} as a list", edited([part], [1, 2]), 400)
for field in ("teeth", "normal_module_mm", "face_width_mm", "tip_radius_mm"):
    add(f"missing gear.{field}", edited(["gear", field], None, delete=True), 400)

# 4. Impossible values, huge numbers, negative teeth (422).
impossible = [
    (["gear", "teeth"], [-37, 0, 2, 4, 10**7, 2**31, -2**31]),
    (["gear", "normal_module_mm"], [0, -6, 1e308, 1e-320]),
    (["gear", "normal_pressure_angle_deg"], [0, -20, 45, 90, 1e300]),
    (["gear", "helix_angle_deg"], [-15, 60, 89.9, 1e300]),
    (["gear", "face_width_mm"], [0, -78, 1e308]),
    (["gear", "tip_radius_mm"], [0, -1, 100, 1e308]),
    (["gear", "root_radius_mm"], [0, -107, 200, 1e308]),
    (["wheel", "radius_mm"], [0, -350, 1e308, 5]),
    (["machine", "k1_mm"], [1e308, -1e308]),
    (["grid", "profile_points"], [0, 1, -5, 100000]),
    (["grid", "lead_points"], [0, 1, -9, 100000]),
    (["grid", "profile_range"], [[0.9, 0.2], [-1, 0.5], [0.2, 1.5], [0.5, 0.5]]),
    (["grid", "lead_range"], [[0.4, -0.4], [-0.9, 0.4], [0.0, 0.0]]),
    (["gear", "hand"], ["up", "LEFT", "", "left; DROP TABLE jobs;--"]),
    (["flank"], ["middle", "Right", "' OR 1=1 --"]),
    (["machine", "kind"], ["hob", "flat-wheel-grinder\u0000"]),
]
for field, values in impossible:
    for value in values:
        add(f"{'.'.join(field)} = {str(value)[:30]}", edited(field, value), 422)
# A wheel too small to generate the flank from root to tip.
add("wheel too small to reach the grid", edited(["wheel", "radius_mm"], 10), 422)

# 5. Wrong grid shapes in the measurement, target and weights.
grid = BASE["measurement"]["deviations_um"]
shapes = {"4 rows": grid[:4], "6 rows": grid + [grid[0]], "short row": [grid[0][:8]] + grid[1:],
          "long row": [grid[0] + [1.0]] + grid[1:], "flat list": sum(grid, []), "nested deeper": [[row] for row in grid],
          "string entry": [["x"] * 9] + grid[1:], "object rows": [{"a": 1}] * 5, "empty": [], "number": 3,
          "bool entries": [[True] * 9] + grid[1:]}
for name, value in shapes.items():
    add(f"measurement {name}", edited(["measurement", "deviations_um"], value), 400)
add("measurement entry 1e300", edited(["measurement", "deviations_um"], [[1e300] * 9] + grid[1:]), 422)
add("measurement all null", edited(["measurement", "deviations_um"], [[None] * 9] * 5), 422)
add("measurement teeth not a list", edited(["measurement"], {"teeth": 5}), 400)
add("measurement teeth with a short grid", edited(["measurement"], {"teeth": [grid, grid[:3]]}), 400)
add("target grid with null", dict(copy.deepcopy(BASE), target={"deviations_um": [[None] * 9] * 5}), 400)
# Strict input (issue 17): an unknown key is a 422 naming it.
add("target neither grid nor modifications", dict(copy.deepcopy(BASE), target={"x": 1}), 422)
add("options typo default_max_ordr", dict(copy.deepcopy(BASE), options={"default_max_ordr": 2}), 422)
add("gear typo modul", edited(["gear", "modul"], 6), 422)
add("machine traverse per degree", edited(["machine", "traverse_mm_per_deg"], 0), 422)
add("measurement in nm", edited(["measurement", "deviations_um"], [[500.5] * 9 for _ in range(5)]), 422)
add("target modification amount 1e308",
    dict(copy.deepcopy(BASE), target={"modifications": [{"kind": "profile_crowning", "amount_um": 1e308}]}), 422)
add("options max_order unknown block", dict(copy.deepcopy(BASE), options={"max_order": {"Q": 2}}), 422)
add("target modification unknown kind", dict(copy.deepcopy(BASE), target={"modifications": [{"kind": "wobble", "amount_um": 1}]}), 422)
add("target modification without amount", dict(copy.deepcopy(BASE), target={"modifications": [{"kind": "lead_crowning"}]}), 400)
# Strict input at the top level of every body, and in the bevel job and simulation scenario
# objects (issue 17): 422 naming the key. The corpus test sees that nothing is stored.
SETUP = {k: BASE[k] for k in ("gear", "wheel", "machine", "grid", "flank")}
BEVEL_JOB = {"side": "convex", "published": True, "grid": {"profile_points": 3, "lengthwise_points": 3}}
BEVEL = {"machine": {"kind": "free-form-bevel-generator"}, "job": BEVEL_JOB,
         "measurement": {"deviations_um": [[0.5, 0.0, 0.1]] * 3}}
SPLIT = {"gear": {"teeth": 75, "pitch_angle_deg": 70, "outer_transverse_module_mm": 40, "face_width_mm": 240,
                  "mean_spiral_angle_deg": 35, "hand": "right", "pressure_angle_deg": 20},
         "tool": {"radius_mm": 8}, "cut": {"steps": 5}}
SHAVING = {"work_gear": {"teeth": 19, "normal_module_mm": 6, "normal_pressure_angle_deg": 20,
                         "helix_angle_deg": 9.91, "hand": "right", "face_width_mm": 75},
           "cutter": dict(GEAR), "grid": {"profile_points": 3, "lead_points": 3}}
for path, body, key in [
        (CORRECTIONS, BASE, "measurment"), (CORRECTIONS, BASE, "allow_large_deviation"),
        (CORRECTIONS, BASE, "job"), (CORRECTIONS, BEVEL, "motions"), (CORRECTIONS, BEVEL, "gear"),
        ("/api/v1/nominal", SETUP, "flnak"), ("/api/v1/evaluate", SETUP, "setings"),
        ("/api/v1/sensitivity", SETUP, "grids"), ("/api/v1/simulations/measurement", SETUP, "noise_mm"),
        ("/api/v1/simulations/measurement", {k: BEVEL[k] for k in ("machine", "job")}, "missing_points"),
        ("/api/v1/simulations/closed-loop", SETUP, "correction"),
        ("/api/v1/targets/reach", dict(SETUP, target={"modifications": [{"kind": "tip_relief", "amount_um": 5}]}),
         "option"),
        ("/api/v1/bevel/conversions", {"job": BEVEL_JOB}, "option"),
        ("/api/v1/bevel/evaluate", {"job": BEVEL_JOB}, "motions"),
        ("/api/v1/bevel/axis-sensitivity", {"job": BEVEL_JOB}, "error"),
        ("/api/v1/bevel/split-trajectory", SPLIT, "tools"),
        ("/api/v1/shaving/cutter-target", SHAVING, "centre_distance"),
        ("/api/v1/measurements/import", {"gear": GEAR, "format": "mka", "content": "HEADER KS.MK.FILE\r\n"}, "toth")]:
    add(f"{path}: unknown top-level key {key}", dict(copy.deepcopy(body), **{key: 1}), 422, path=path)
add("batch: item with an unknown key", {"items": [dict(copy.deepcopy(BASE), tolerence={"rms_um": 2})]}, 422,
    path="/api/v1/batches")
add("batch: unknown key item", {"item": [BASE]}, 422, path="/api/v1/batches")


def with_key(body, where, key):
    request = copy.deepcopy(body)
    node = request
    for k in where:
        node = node.setdefault(k, {})
    node[key] = 1
    return request


for where, key in [(["job"], "publishd"), (["job", "cutter"], "point_radius"), (["job", "machine"], "ratio_of_rol"),
                   (["job", "blank"], "face_angle_dg"), (["job", "grid"], "profile_point"), (["machine"], "knd")]:
    add(f"bevel correction: unknown key {'.'.join(where)}.{key}", with_key(BEVEL, where, key), 422)
ZERO_MOTION = {a: [0.0] for a in ("A_rad", "B_rad", "X_mm", "Y_mm", "Z_mm")}
for path, body, where, key in [
        ("/api/v1/bevel/conversions", {"job": BEVEL_JOB}, ["options"], "polynomial_degre"),
        ("/api/v1/bevel/axis-sensitivity", {"job": BEVEL_JOB}, ["errors"], "exakt"),
        ("/api/v1/bevel/evaluate", {"job": BEVEL_JOB, "motion": ZERO_MOTION}, ["motion"], "Z_mn"),
        ("/api/v1/simulations/measurement", {k: BEVEL[k] for k in ("machine", "job")}, ["hidden_errors"], "X_m"),
        ("/api/v1/simulations/measurement", SETUP, ["hidden_errors"], "axis"),
        ("/api/v1/simulations/closed-loop", SETUP, ["hidden_errors", "wheel"], "cone_angle_dg"),
        ("/api/v1/simulations/measurement", SETUP, ["random_hidden_errors"], "block_sise"),
        ("/api/v1/bevel/split-trajectory", SPLIT, ["cut"], "step"),
        ("/api/v1/bevel/split-trajectory", SPLIT, ["output"], "nc_program"),
        ("/api/v1/shaving/cutter-target", SHAVING, ["diagonal_modification"], "tip_bands"),
        ("/api/v1/shaving/cutter-target", SHAVING, ["wheel_check"], "hs_mm")]:
    add(f"{path}: unknown key {'.'.join(where)}.{key}", with_key(body, where, key), 422, path=path)
# The 500 um rule on target grids (issue 17), as on measured grids.
NM_TARGET = [[0.0] * 9] * 4 + [[0.0] * 8 + [700.0]]
add("target grid in nm", dict(copy.deepcopy(BASE), target={"deviations_um": NM_TARGET}), 422)
add("closed loop: target grid in nm", dict(copy.deepcopy(SETUP), corrections=1, target={"deviations_um": NM_TARGET}),
    422, path="/api/v1/simulations/closed-loop")
add("bevel correction: target grid in nm",
    dict(copy.deepcopy(BEVEL), target={"deviations_um": [[0.0] * 3, [0.0, 0.0, 501.0], [0.0] * 3]}), 422)
add("target modification fraction 0", dict(copy.deepcopy(BASE), target={"modifications": [{"kind": "tip_relief", "amount_um": 5, "length_fraction": 0}]}), 422)
add("target modification bad shape", dict(copy.deepcopy(BASE), target={"modifications": [{"kind": "tip_relief", "amount_um": 5, "shape": "cubic"}]}), 422)
add("weights with negative entries", dict(copy.deepcopy(BASE), options={"point_weights": [[-1.0] * 9] * 5}), 422)
add("weights of the wrong shape", dict(copy.deepcopy(BASE), options={"point_weights": [[1.0] * 9] * 4}), 400)

# 6. Options out of range.
for name, options, expect in [
        ("solver unknown", {"solver": "magic"}, 422), ("solver a number", {"solver": 1}, 400),
        ("mode unknown", {"mode": "sideways"}, 422), ("max_order out of range", {"max_order": {"C": 99}}, 422),
        ("max_order not integer", {"max_order": {"C": 1.5}}, 400), ("iterations negative", {"max_num_iterations": -1}, 422),
        ("iterations huge", {"max_num_iterations": 10**9}, 422), ("pso particles huge", {"pso_particles": 100000}, 422),
        ("pso generations huge", {"pso_generations": 10**8}, 422), ("noise negative", {"probe_noise_um": -0.1}, 422),
        ("block scale zero", {"block_scales": {"X": 0}}, 422), ("options a list", [1], 400),
        ("outlier fraction 1", {"max_outlier_fraction": 1.0}, 422),
        ("swarm too large", {"solver": "pso", "pso_particles": 200, "pso_generations": 2000}, 422)]:
    add(f"options: {name}", dict(copy.deepcopy(BASE), options=options), expect)
add("settings_source_job_id unknown", dict(copy.deepcopy(BASE), settings_source_job_id=424242), 422)
add("settings_source_job_id negative", dict(copy.deepcopy(BASE), settings_source_job_id=-1), 422)
add("settings_source_job_id a string", dict(copy.deepcopy(BASE), settings_source_job_id="1; DROP TABLE jobs"), 400)
bad_settings = {"axes": {"X": [1.0]}}
add("settings missing axes", dict(copy.deepcopy(BASE), settings=bad_settings), 400)
add("settings axis too long", dict(copy.deepcopy(BASE), settings={"axes": {a: [0.0] * 8 for a in "XYZABC"}}), 400)
add("settings axis huge", dict(copy.deepcopy(BASE), settings={"axes": {a: [1e300] for a in "XYZABC"}}), 422)
add("settings cone 90 deg", dict(copy.deepcopy(BASE), settings={"axes": {a: [0.0] for a in "XYZABC"}, "wheel": {"cone_angle_deg": 90}}), 422)

# 7. Deeply nested JSON.
for depth in (33, 100, 1000, 20000):
    add(f"nested arrays depth {depth}", "[" * depth + "]" * depth, 400)
    add(f"nested objects depth {depth}", "{\"a\":" * depth + "1" + "}" * depth, 400)
add("nested measurement", edited(["measurement", "deviations_um"], json.loads("[" * 30 + "]" * 30)), 400)

# 8. Bad UTF-8 and control bytes.
for i, raw in enumerate([b"{\"flank\": \"\xff\"}", b"{\"gear\": \"\xc3\x28\"}", b"{\"\xed\xa0\x80\": 1}",
                         b"{\"a\": \"\xf4\x90\x80\x80\"}", b"\xff\xfe{\x00}\x00", b"{\"a\": \"\x01\"}",
                         b"{\"a\": \"\\ud800\"}"]):
    add(f"bad utf-8 {i}", raw=raw, expect=400)

# 9. Unknown routes and methods.
for path in ["/", "/api", "/api/v1", "/api/v2/corrections", "/api/v1/correction", "/api/v1/corrections/abc",
             "/api/v1/corrections/-1", "/api/v1/corrections/1;DROP%20TABLE%20jobs", "/api/v1/corrections/0",
             "/api/v1/corrections/99999999999999999999999999", "/../../etc/passwd", "/api/v1/../../etc/passwd",
             "/api/v1/batches/abc", "/api/v1/simulations", "/static/../server/main.cc", "/%00"]:
    expect = 200 if path == "/" else 404
    if path == "/":
        continue  # the dashboard
    add(f"GET {path}", "", expect, method="GET", path=path)
for method, path in [("PUT", "/api/v1/corrections"), ("DELETE", "/api/v1/corrections/1"), ("PATCH", "/api/v1/nominal"),
                     ("GET", "/api/v1/nominal"), ("GET", "/api/v1/evaluate"), ("GET", "/api/v1/batches"),
                     ("POST", "/healthz"), ("POST", "/metrics"), ("PUT", "/api/v1/simulations/closed-loop"),
                     ("DELETE", "/api/v1/batches/1"), ("OPTIONS", "/api/v1/corrections")]:
    add(f"{method} {path}", "{}", 405, method=method, path=path)

# 10. Query strings of the history.
for query, expect in [("limit=-1", 422), ("limit=0", 422), ("limit=1e3", 400), ("limit=99999999999999", 400),
                      ("offset=-5", 422), ("teeth=abc", 400), ("module_mm=NaN", 400), ("flank=%27%20OR%201%3D1",
                      422), ("created_from=yesterday", 400), ("created_to=2026-13-45T99", 400),
                      ("created_from=2026-11-22&created_to=2026-01-01", 422),
                      ("created_from=2026-11-22%27%3B%20DROP%20TABLE%20jobs%3B--", 400)]:
    add(f"history query {query}", "", expect, method="GET", path="/api/v1/corrections?" + query)

# 11. Other endpoints.
for path in ("/api/v1/nominal", "/api/v1/evaluate", "/api/v1/sensitivity", "/api/v1/simulations/measurement",
             "/api/v1/simulations/closed-loop"):
    add(f"{path}: broken json", "{\"gear\"", 400, path=path)
    add(f"{path}: impossible gear", edited(["gear", "teeth"], 1), 422, path=path)
add("simulation: noise negative", dict(copy.deepcopy(BASE), noise_um=-1), 422, path="/api/v1/simulations/measurement")
add("simulation: teeth 1000", dict(copy.deepcopy(BASE), teeth=1000), 422, path="/api/v1/simulations/measurement")
add("simulation: missing point outside", dict(copy.deepcopy(BASE), missing_points=[[5, 0]]), 422,
    path="/api/v1/simulations/measurement")
add("simulation: both error kinds", dict(copy.deepcopy(SETUP), hidden_errors={}, random_hidden_errors={}), 400,
    path="/api/v1/simulations/measurement")
add("simulation: hidden axis unknown", dict(copy.deepcopy(SETUP), hidden_errors={"axes": {"W": [1]}}), 400,
    path="/api/v1/simulations/measurement")
add("closed loop: 1000 corrections", dict(copy.deepcopy(BASE), corrections=1000), 422,
    path="/api/v1/simulations/closed-loop")
add("batch: items not a list", {"items": "all"}, 400, path="/api/v1/batches")
add("batch: 1001 items", {"items": [{}] * 1001}, 422, path="/api/v1/batches")
add("batch: item a number", {"items": [1]}, 400, path="/api/v1/batches")
add("replay of a missing job", "{}", 404, path="/api/v1/corrections/424242/replay")

# 12. Measuring-machine files (issue 15): POST /api/v1/measurements/import and a correction's
#     measurement.file; every refusal a 4xx (invalid_file 422 naming the line or element path).
#     A file over 4 MiB (413) is tested in tests/server/measurement_import_test.cc, not kept here.
IMPORT = "/api/v1/measurements/import"
SAMPLE_GEAR = {"teeth": 31, "normal_module_mm": 4.5, "normal_pressure_angle_deg": 20, "helix_angle_deg": 20,
               "hand": "right", "face_width_mm": 40, "tip_radius_mm": 78.726, "root_radius_mm": 68.601}
MKA_HEAD = ("HEADER KS.MK.FILE\r\nUNDEFINED  -2147483.648\r\n   21 :mn: 4.5\r\n   22 :z: 31\r\n"
            "   23 :beta: 20\r\n   24 :alpha: 20\r\n   26 :b: 40\r\n   41 :da: 140.5 140.5\r\n"
            "   44 :de: 157 157\r\n   61 :ba: 1 1\r\n   64 :be: 39 39\r\n")
# One well-formed profile trace, so that the checks behind the reader (ranges, base circle, the
# request's gear) are reached.
MKA_TRACE = "TOPOGRAFIE: Zahn-Nr.: 1 /Profil:1 rechts / 3 Werte  / z= 20.000\r\n 1.0 2.0 3.0\r\n"


def import_body(format, content, **extra):
    return dict({"gear": SAMPLE_GEAR, "flank": "right", "format": format, "content": content}, **extra)


for name, content in [
        ("empty", ""), ("whitespace", " \r\n "), ("value file", "HEADER KS.MW.FILE\r\n"),
        ("no header", "TOPOGRAFIE: Zahn-Nr.: 1 /Profil:1 rechts / 2 Werte  / z= 3.000\r\n 1 2\r\n"),
        ("NUL byte", "HEADER KS.MK.FILE\x00\r\n"), ("control characters", "HEADER KS.MK.FILE\r\n\x07\x1b[2J"),
        ("decimal comma", MKA_HEAD.replace("4.5", "4,5")), ("NaN header", MKA_HEAD.replace("4.5", "NaN")),
        ("inf header", MKA_HEAD.replace("4.5", "1e999")), ("repeated code", MKA_HEAD + "   21 :mn: 4.5\r\n"),
        ("huge value count", MKA_HEAD + "TOPOGRAFIE: Zahn-Nr.: 1 /Profil:1 rechts / 999999999 Werte  / z= 3.000\r\n"),
        ("negative value count", MKA_HEAD + "TOPOGRAFIE: Zahn-Nr.: 1 /Profil:1 rechts / -5 Werte  / z= 3.000\r\n"),
        ("too few values", MKA_HEAD + "TOPOGRAFIE: Zahn-Nr.: 1 /Profil:1 rechts / 48 Werte  / z= 3.000\r\n 1 2 3\r\n"),
        ("one value", MKA_HEAD + "TOPOGRAFIE: Zahn-Nr.: 1 /Profil:1 rechts / 1 Werte  / z= 3.000\r\n 1\r\n"),
        ("range the wrong way", MKA_HEAD.replace("157 157", "130 130") + MKA_TRACE),
        ("inside the base circle", MKA_HEAD.replace("140.5 140.5", "100 100") + MKA_TRACE),
        ("no traces", MKA_HEAD),
        ("module contradicts the request", MKA_HEAD.replace("4.5", "5.0") + MKA_TRACE)]:
    add(f"import mka: {name}", import_body("mka", content), "4xx", path=IMPORT)
GDE_HEAD = '<?xml version="1.0"?>'
for name, content in [
        ("not XML", "GDE"), ("unclosed", GDE_HEAD + "<GDE><GEAR_DATA>"), ("wrong root", GDE_HEAD + "<VDI/>"),
        ("deep nesting", GDE_HEAD + "<GDE>" + "<a>" * 5000 + "</a>" * 5000 + "</GDE>"),
        ("entity expansion", GDE_HEAD + '<!DOCTYPE GDE [<!ENTITY a "aaaaaaaaaa"><!ENTITY b "&a;&a;&a;&a;&a;&a;">'
         '<!ENTITY c "&b;&b;&b;&b;&b;&b;">]><GDE>&c;&c;&c;&c;</GDE>'),
        ("external entity", GDE_HEAD + '<!DOCTYPE GDE [<!ENTITY x SYSTEM "file:///etc/passwd">]><GDE>&x;</GDE>'),
        ("no net", GDE_HEAD + '<GDE version="3.4"><GEAR_DATA/></GDE>'),
        ("bad number", GDE_HEAD + '<GDE><GEAR_DATA><GEOMETRY><BASIC_GEOMETRY><number_of_teeth>3l</number_of_teeth>'
         '</BASIC_GEOMETRY></GEOMETRY></GEAR_DATA></GDE>'),
        ("unknown unit", GDE_HEAD + '<GDE><GEAR_DATA><GEOMETRY><BASIC_GEOMETRY><normal_module unit="furlong">4.5'
         '</normal_module></BASIC_GEOMETRY></GEOMETRY></GEAR_DATA></GDE>')]:
    add(f"import gde: {name}", import_body("gde", content), "4xx", path=IMPORT)
for name, body, expect in [
        ("format unknown", import_body("csv", MKA_HEAD), 422), ("format a number", import_body(3, MKA_HEAD), 400),
        ("content a number", import_body("mka", 42), 400), ("content null", import_body("mka", None), 400),
        ("no content", {"gear": SAMPLE_GEAR, "format": "mka"}, 400), ("no gear", {"format": "mka", "content": "x"}, 400),
        ("tooth huge", import_body("mka", MKA_HEAD, tooth=10 ** 12), 422),
        ("tooth text", import_body("mka", MKA_HEAD, tooth="1"), 400),
        ("datum face unknown", import_body("mka", MKA_HEAD, datum_face="top"), 422),
        ("sign factor 0", import_body("mka", MKA_HEAD, sign_factors={"helix_right": 0}), 422),
        ("sign factors a list", import_body("mka", MKA_HEAD, sign_factors=[1, -1]), 400),
        ("flank up", import_body("mka", MKA_HEAD, flank="up"), 422),
        ("grid 1 point", import_body("mka", MKA_HEAD, grid={"profile_points": 1}), 422)]:
    add(f"import: {name}", body, expect, path=IMPORT)
add("correction: measurement file broken", dict(copy.deepcopy(BASE), measurement={"file": {"format": "mka",
    "content": "HEADER KS.MK.FILE\r\n   21 :mn: x\r\n"}}), 422)
add("correction: measurement file and grid", dict(copy.deepcopy(BASE), measurement={
    "file": {"format": "mka", "content": MKA_HEAD}, "deviations_um": BASE["measurement"]["deviations_um"]}), 400)
add("correction: measurement file a string", dict(copy.deepcopy(BASE), measurement={"file": "part.mka"}), 400)
add("correction: bevel with a measurement file", {"machine": {"kind": "free-form-bevel-generator"},
    "job": {"side": "convex", "published": True}, "measurement": {"file": {"format": "mka", "content": MKA_HEAD}}},
    422)
add("export of a missing job", "", 404, method="GET", path="/api/v1/corrections/424242/export?format=gde")

for case in cases:
    sys.stdout.write(json.dumps(case, ensure_ascii=True) + "\n")
sys.stderr.write(f"{len(cases)} cases\n")
