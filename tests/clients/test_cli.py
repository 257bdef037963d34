"""Tests of the `gearloop` command-line client ($GEARLOOP_CLI_BIN) against a real gearloop-server:
every subcommand, its exit code, and what it prints or writes."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import tempfile
import threading
import unittest
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

from gearloop_client import read_csv_grid
from server_fixture import EXAMPLES, RunningServer, free_port, write_token_file

CLI = os.environ.get("GEARLOOP_CLI_BIN", "")
# The sample files of shared/formats (copies kept in tests/formats/data) and their gear.
SAMPLES = Path(__file__).resolve().parent.parent / "formats" / "data"
SAMPLE_SETUP = {
    "gear": {"teeth": 31, "normal_module_mm": 4.5, "normal_pressure_angle_deg": 20, "helix_angle_deg": 20,
             "hand": "right", "face_width_mm": 40, "tip_radius_mm": 78.726, "root_radius_mm": 68.601},
    "wheel": {"radius_mm": 350},
    "flank": "right",
}


class CliTest(unittest.TestCase):
    server: RunningServer

    @classmethod
    def setUpClass(cls) -> None:
        if not CLI or not os.path.exists(CLI):
            raise RuntimeError("set GEARLOOP_CLI_BIN to the gearloop binary (ctest does)")
        cls.server = RunningServer().__enter__()
        cls.tmp = tempfile.TemporaryDirectory(prefix="gearloop-cli-")
        cls.dir = Path(cls.tmp.name)

    @classmethod
    def tearDownClass(cls) -> None:
        cls.server.__exit__(None, None, None)
        cls.tmp.cleanup()

    def run_cli(self, *args: str, server: str = "") -> subprocess.CompletedProcess:
        env = dict(os.environ)
        env.pop("GEARLOOP_TOKEN", None)
        return subprocess.run([CLI, "--server", server or self.server.url, *args], capture_output=True, text=True,
                              timeout=300, env=env)

    def assert_server_refused(self, expected: str, *args: str) -> None:
        """The CLI exits 3 (the server refused the request) and repeats the server's words."""
        done = self.run_cli(*args)
        self.assertEqual(done.returncode, 3, done.stderr)
        self.assertIn(expected, done.stderr)

    def submit(self, *extra: str) -> dict:
        done = self.run_cli("--json", "submit", str(EXAMPLES / "request.json"), str(EXAMPLES / "measurement.csv"), *extra)
        self.assertIn(done.returncode, (0, 5), done.stderr)
        job = json.loads(done.stdout)
        # Exit 0 exactly when the correction converged.
        self.assertEqual(done.returncode == 0, job["result"]["status"] == "converged")
        return job

    def test_help_and_usage_errors(self) -> None:
        done = self.run_cli("--help")
        self.assertEqual(done.returncode, 0)
        for word in ("submit", "batch", "closed-loop", "report", "exit codes", "--token"):
            self.assertIn(word, done.stdout)
        for command in ("submit", "list", "show", "replay", "batch", "simulate", "closed-loop", "report", "health",
                        "nominal", "evaluate", "bevel-convert", "bevel-closed-loop", "import", "correct",
                        "export", "settings", "lineage", "bevel-sensitivity", "reach"):
            sub = self.run_cli(command, "--help")
            self.assertEqual(sub.returncode, 0, command)
            self.assertIn("usage: gearloop " + command, sub.stdout)
        self.assertEqual(self.run_cli("frobnicate").returncode, 1)
        self.assertEqual(self.run_cli("show").returncode, 1)
        self.assertEqual(self.run_cli("show", "abc").returncode, 1)
        self.assertEqual(self.run_cli("list", "--bogus").returncode, 1)

    def test_health_and_unreachable_server(self) -> None:
        done = self.run_cli("health")
        self.assertEqual(done.returncode, 0, done.stderr)
        self.assertIn("server ok", done.stdout)
        dead = self.run_cli("--timeout", "5", "health", server=f"http://127.0.0.1:{free_port()}")
        self.assertEqual(dead.returncode, 2)
        self.assertIn("cannot reach http://127.0.0.1:", dead.stderr)
        self.assertIn("Is the server running?", dead.stderr)
        self.assertIn("--server URL or GEARLOOP_SERVER", dead.stderr)

    def test_submit_csv_and_json_measurements(self) -> None:
        residual_csv = self.dir / "residual.csv"
        settings_out = self.dir / "settings.json"
        job = self.submit("--residual-csv", str(residual_csv), "--settings-out", str(settings_out))
        residual = read_csv_grid(str(residual_csv))
        self.assertAlmostEqual(residual[2][4], job["result"]["predicted_residual_um"][2][4], places=9)
        self.assertIn("axes", json.loads(settings_out.read_text()))

        human = self.run_cli("submit", str(EXAMPLES / "request.json"), str(EXAMPLES / "measurement.json"))
        self.assertIn(human.returncode, (0, 5), human.stderr)
        self.assertIn("predicted residual", human.stdout)
        self.assertIn("row 5 tip", human.stdout)
        # How sure the prediction is: the expected true rms and its 2-sigma band.
        self.assertRegex(human.stdout, r"next part true rms   [0-9.]+ um, 2 sigma [0-9.]+\.\.[0-9.]+ um \(noise [0-9.]+ um (stated|estimated)( from the measurement's scatter; [0-9.]+ um stated is contradicted)?\)")
        # The wheel parabola the safe step hedged: shown or assumed.
        self.assertRegex(human.stdout, r"wheel parabola       ([0-9.]+ \+- [0-9.]+ um rms of flank as the measurement shows it|[0-9.]+ um rms of flank assumed \(noise not known\))\n")

    def test_submit_says_when_the_measurement_contradicts_the_stated_noise(self) -> None:
        # The example measurement scatters ~0.05 um from point to point; 0.01 um stated is
        # contradicted, and the line says which noise was used and what was stated.
        options = Path(self.tmp.name) / "understated-noise.json"
        options.write_text(json.dumps({"probe_noise_um": 0.01}))
        human = self.run_cli("submit", str(EXAMPLES / "request.json"), str(EXAMPLES / "measurement.json"),
                             "--options", str(options))
        self.assertIn(human.returncode, (0, 5), human.stderr)
        self.assertRegex(human.stdout, r"\(noise [0-9.]+ um estimated from the measurement's scatter; "
                                       r"0\.010 um stated is contradicted\)")

    def test_submit_says_when_the_estimated_noise_is_a_misfit_read_as_flank(self) -> None:
        # A +-3 um checkerboard on the example measurement: no axis motion makes it, no noise is
        # stated, so the noise is estimated from the misfit, above what a probe scatters; the line
        # says the expected value keeps all but the server's noise_read_as_probe_um of it as flank.
        measurement = json.loads((EXAMPLES / "measurement.json").read_text())
        for r, row in enumerate(measurement["deviations_um"]):
            for c, value in enumerate(row):
                if value is not None:
                    row[c] = value + (3.0 if (r + c) % 2 == 0 else -3.0)
        path = self.dir / "checkerboard.json"
        path.write_text(json.dumps(measurement))
        done = self.run_cli("--json", "submit", str(EXAMPLES / "request.json"), str(path))
        self.assertIn(done.returncode, (0, 5), done.stderr)
        band = json.loads(done.stdout)["result"]["prediction_band"]
        self.assertFalse(band["noise_stated"])
        self.assertTrue(band["misfit_read_as_flank"])
        self.assertEqual(band["noise_read_as_probe_um"], 1.0)
        self.assertGreater(band["noise_sigma_um"], 1.0)
        human = self.run_cli("submit", str(EXAMPLES / "request.json"), str(path))
        self.assertIn(human.returncode, (0, 5), human.stderr)
        self.assertRegex(human.stdout, r"\(noise [0-9.]+ um estimated from a misfit, more than a probe scatters: "
                                       r"the expected value counts all but 1\.000 um of it as flank the next part keeps\)")

    def test_submit_several_teeth_shows_their_mean(self) -> None:
        data = Path(__file__).resolve().parent / "data"
        done = self.run_cli("--json", "submit", str(EXAMPLES / "request.json"), str(data / "measurement_teeth.json"))
        self.assertIn(done.returncode, (0, 5), done.stderr)
        job = json.loads(done.stdout)
        measured = read_csv_grid(self.run_cli("show", str(job["id"]), "--grid", "measured").stdout, is_text=True)
        self.assertEqual(measured[0][0], 2.0)   # mean of the two teeth
        self.assertEqual(measured[4][8], 3.0)   # only the second tooth delivered the tip corner

    def test_submit_bad_csv_names_line_and_column(self) -> None:
        bad = self.dir / "bad.csv"
        lines = (EXAMPLES / "measurement.csv").read_text().splitlines()
        lines[5] = lines[5].replace("0.6", "0.6x", 1)  # line 6 of the file: its third data row
        bad.write_text("\n".join(lines) + "\n")
        done = self.run_cli("submit", str(EXAMPLES / "request.json"), str(bad))
        self.assertEqual(done.returncode, 4)
        self.assertIn("bad.csv: line 6, column 3: '0.6x' is not a number", done.stderr)
        missing = self.run_cli("submit", str(EXAMPLES / "request.json"), str(self.dir / "nope.csv"))
        self.assertEqual(missing.returncode, 4)

    def test_submit_invalid_request_is_api_error(self) -> None:
        request = json.loads((EXAMPLES / "request.json").read_text())
        request["gear"]["teeth"] = -3
        path = self.dir / "bad_request.json"
        path.write_text(json.dumps(request))
        self.assert_server_refused("422 invalid_value at gear.teeth", "submit", str(path), str(EXAMPLES / "measurement.csv"))

    def test_list_show_and_grid_export(self) -> None:
        job = self.submit()
        listed = self.run_cli("list", "--limit", "50")
        self.assertEqual(listed.returncode, 0, listed.stderr)
        self.assertRegex(listed.stdout, rf"(?m)^{job['id']}\s+\d{{4}}-")
        as_json = json.loads(self.run_cli("--json", "list", "--limit", "2").stdout)
        self.assertLessEqual(len(as_json["jobs"]), 2)

        shown = self.run_cli("show", str(job["id"]))
        self.assertEqual(shown.returncode, 0, shown.stderr)
        self.assertIn("measured", shown.stdout)
        self.assertIn("37 teeth", shown.stdout)
        measured = self.run_cli("show", str(job["id"]), "--grid", "measured")
        self.assertEqual(read_csv_grid(measured.stdout, is_text=True), read_csv_grid(str(EXAMPLES / "measurement.csv")))
        target = read_csv_grid(self.run_cli("show", str(job["id"]), "--grid", "target").stdout, is_text=True)
        # Lead crowning of 4 um: the middle of the lead is highest.
        self.assertGreater(target[2][4], target[2][0])
        # The server's target grid (the modifications it evaluated), not one rebuilt from the others.
        for row, server_row in zip(target, job["result"]["target_um"]):
            for value, server_value in zip(row, server_row):
                self.assertAlmostEqual(value, server_value, places=6)
        # The correction as axis motion: one row per axis, its change at 9 roll angles, rms and max.
        self.assertIn("axis motion of the correction", shown.stdout)
        x_row = next(line for line in shown.stdout.splitlines() if line.startswith("X [um]"))
        x_motion = job["result"]["axis_motion"]["axes"]["X"]
        self.assertEqual(len(x_row.split()), 2 + 9 + 2)
        self.assertEqual(x_row.split()[-1], f"{x_motion['max_abs_um']:.2f}")
        self.assertEqual(x_row.split()[2], f"{x_motion['change_um'][0]:.2f}")
        self.assertRegex(shown.stdout, r"(?m)^A \[urad\] ")
        self.assertEqual(self.run_cli("show", "999999").returncode, 3)

    def test_exact_model_search_in_submit_and_show(self) -> None:
        job = self.submit()
        outcome = job["result"]["exact_search"]["outcome"]
        self.assertTrue(outcome)
        for done in (self.run_cli("submit", str(EXAMPLES / "request.json"), str(EXAMPLES / "measurement.csv")),
                     self.run_cli("show", str(job["id"]))):
            self.assertIn("\n  exact-model search " + outcome + "\n", done.stdout)
        # The two exact predictions when the search ran (a null one as "-"), and a job stored
        # before the field existed (nothing said), from a server answering this job so.
        stored = json.loads(self.run_cli("--json", "show", str(job["id"])).stdout)
        stored["result"]["exact_search"] = {
            "outcome": "taken: the exact model at the linearisation point predicts 0.27 um against 9.1 um",
            "regularised_predicted_rms_um": 9.1, "searched_predicted_rms_um": 0.27}
        shown = run_against_canned(CannedJobServer, stored, "show", str(job["id"]))
        self.assertEqual(shown.returncode, 0, shown.stderr)
        self.assertIn("\n  exact-model search taken: the exact model at the linearisation point predicts 0.27 um "
                      "against 9.1 um\n    exact-model rms 9.100 um regularised, 0.270 um searched\n", shown.stdout)
        stored["result"]["exact_search"]["searched_predicted_rms_um"] = None
        shown = run_against_canned(CannedJobServer, stored, "show", str(job["id"]))
        self.assertIn("\n    exact-model rms 9.100 um regularised, - um searched\n", shown.stdout)
        del stored["result"]["exact_search"]
        shown = run_against_canned(CannedJobServer, stored, "show", str(job["id"]))
        self.assertEqual(shown.returncode, 0, shown.stderr)
        self.assertIn("linearised at", shown.stdout)
        self.assertNotIn("exact-model", shown.stdout)

    def test_bevel_pinion_job_in_list_and_show(self) -> None:
        import urllib.request

        def post(path: str, body: dict) -> dict:
            request = urllib.request.Request(self.server.url + path, data=json.dumps(body).encode(),
                                             headers={"Content-Type": "application/json"})
            with urllib.request.urlopen(request, timeout=120) as answer:
                return json.load(answer)

        bevel = {"machine": {"kind": "free-form-bevel-generator"}, "job": {"side": "concave", "published": True}}
        cmm = post("/api/v1/simulations/measurement", dict(bevel, hidden_errors={"X_mm": [0.008]}))
        job = post("/api/v1/corrections", dict(bevel, measurement=cmm["measurement"]))
        listed = self.run_cli("list", "--limit", "50")
        self.assertEqual(listed.returncode, 0, listed.stderr)
        self.assertRegex(listed.stdout, rf"(?m)^{job['id']}\s+.*bevel pinion\s+concave")
        shown = self.run_cli("show", str(job["id"]))
        self.assertEqual(shown.returncode, 0, shown.stderr)
        self.assertIn("machine: free-form bevel generator", shown.stdout)
        self.assertIn("concave flank", shown.stdout)
        self.assertRegex(shown.stdout, r"(?m)^  X_mm ")
        measured = read_csv_grid(self.run_cli("show", str(job["id"]), "--grid", "measured").stdout, is_text=True)
        self.assertEqual(len(measured), 5)
        self.assertAlmostEqual(measured[2][4], cmm["measurement"]["deviations_um"][2][4], places=4)

    def test_bevel_convert_published_and_from_file(self) -> None:
        done = self.run_cli("bevel-convert")
        self.assertEqual(done.returncode, 0, done.stderr)
        self.assertIn("concave flank (published summary, Tang 2011): degree 5", done.stdout)
        self.assertIn("fit residual", done.stdout)
        for axis in ("A", "B", "X", "Y", "Z"):
            self.assertRegex(done.stdout, rf"(?m)^{axis}\s+\S+\s+\S+ u(m|rad)$")
        self.assertRegex(done.stdout, r"flank distance to the cradle flank: max \d+\.\d{4} um, rms \d+\.\d{4} um")

        degree3 = json.loads(self.run_cli("--json", "bevel-convert", "--degree", "3").stdout)
        self.assertEqual(degree3["degree"], 3)
        self.assertEqual(len(degree3["motion"]["X_mm"]), 4)
        # The tolerance picks the degree itself, and the flank then lies within it.
        chosen = json.loads(self.run_cli("--json", "bevel-convert", "--max-flank-distance-um", "0.1").stdout)
        self.assertLessEqual(chosen["flank_distance"]["max_um"], 0.1)
        self.assertIn(chosen["degree"], range(2, 13))

        job = self.dir / "pinion.json"
        job.write_text(json.dumps({"side": "convex", "published": True}))
        motion = self.dir / "motion.json"
        from_file = self.run_cli("bevel-convert", str(job), "--motion-out", str(motion))
        self.assertEqual(from_file.returncode, 0, from_file.stderr)
        self.assertIn("convex flank", from_file.stdout)
        self.assertEqual(len(json.loads(motion.read_text())["Z_mm"]), 6)

    def test_bevel_convert_bad_input(self) -> None:
        self.assert_server_refused("422 invalid_value at options.polynomial_degree", "bevel-convert", "--degree", "13")
        self.assert_server_refused("at options.max_flank_distance_um", "bevel-convert", "--degree", "4",
                                   "--max-flank-distance-um", "0.1")
        self.assertEqual(self.run_cli("bevel-convert", "--degree", "four").returncode, 1)
        self.assertEqual(self.run_cli("bevel-convert", "--side", "left").returncode, 1)
        self.assertEqual(self.run_cli("bevel-convert", str(self.dir / "nope.json")).returncode, 4)

    def test_bevel_closed_loop_and_show_of_its_jobs(self) -> None:
        done = self.run_cli("bevel-closed-loop", "--error", "X_mm=0.008", "--noise", "0.1", "--seed", "2",
                            "--corrections", "2", "--store")
        self.assertEqual(done.returncode, 0, done.stderr)
        self.assertIn("true rms", done.stdout)
        self.assertIn("part 0 is cut before any correction", done.stdout)
        rows = [line.split() for line in done.stdout.splitlines() if line.split() and line.split()[0].isdigit()]
        self.assertEqual([row[0] for row in rows], ["0", "1", "2"])
        # The hidden X error is corrected away: the last part is truer than the first.
        self.assertLess(float(rows[-1][1]), float(rows[0][1]))
        job_id = rows[0][5]
        shown = self.run_cli("show", job_id)
        self.assertEqual(shown.returncode, 0, shown.stderr)
        self.assertIn("machine: free-form bevel generator", shown.stdout)
        self.assertIn("(closed_loop)", shown.stdout)
        self.assertRegex(shown.stdout, r"(?m)^  X_mm ")

        as_json = json.loads(self.run_cli("--json", "bevel-closed-loop", "--side", "convex", "--error",
                                          "A_rad=0,2e-5", "--corrections", "1").stdout)
        self.assertEqual(as_json["machine_kind"], "free-form-bevel-generator")
        self.assertEqual(len(as_json["iterations"]), 2)
        self.assertAlmostEqual(as_json["hidden_errors"]["A_rad"][1], 2e-5)

        self.assertEqual(self.run_cli("bevel-closed-loop", "--error", "X_mm=big").returncode, 1)
        self.assert_server_refused("at corrections", "bevel-closed-loop", "--corrections", "50")
        self.assert_server_refused("at hidden_errors.Q_mm", "bevel-closed-loop", "--error", "Q_mm=0.01", "--corrections", "1")

    def test_split_trajectory_flags_file_nc_and_show(self) -> None:
        wheel = ["--teeth", "75", "--pitch-angle-deg", "70", "--module-mm", "40", "--face-width-mm", "240",
                 "--spiral-angle-deg", "35", "--hand", "right", "--pressure-angle-deg", "20",
                 "--tool-radius-mm", "8", "--stock-mm", "0.2"]
        nc_path = self.dir / "slot3.nc"
        done = self.run_cli("split-trajectory", *wheel, "--slot", "3", "--levels", "4", "--steps", "5",
                            "--pivot-mm", "300", "--nc", str(nc_path))
        self.assertEqual(done.returncode, 0, done.stderr)
        rows = [line.split() for line in done.stdout.splitlines() if line.split()[:1] and line.split()[0].isdigit()]
        self.assertEqual([(r[1], r[2], r[3]) for r in rows],
                         [(f, str(j), "5") for f in ("convex", "concave") for j in range(4)])
        # pass flank level stations A_lo .. A_hi B_lo .. B_hi max_dev mm
        self.assertEqual((rows[0][4], rows[0][6]), ("15.529", "17.388"))
        self.assertEqual((rows[0][7], rows[0][9]), ("5.297", "11.244"))
        self.assertAlmostEqual(float(rows[0][10]), 0.2, places=4)
        nc = nc_path.read_text()
        self.assertTrue(nc.startswith("%\n(GEARLOOP SPLIT-BEVEL 1)\n"))
        self.assertIn("G01 X1336.2082 Y-43.8387 Z-168.4312 A17.3882 B11.2437 F200.0\n", nc)
        self.assertTrue(nc.endswith("M30\n%\n"))
        job_id = done.stdout.split()[1]
        shown = self.run_cli("show", job_id)
        self.assertEqual(shown.returncode, 0, shown.stderr)
        self.assertIn("split_trajectory", shown.stdout)
        self.assertRegex(shown.stdout, r"(?m)^\s+8\s+concave\s+3\s+5\s")
        listed = self.run_cli("list", "--kind", "split_trajectory")
        self.assertRegex(listed.stdout, rf"(?m)^{job_id}\s+\S+\s+split_trajectory\s+computed\s+75z mn30.303\s+both")
        # A request file; the options set members over it.
        request = {"gear": {"teeth": 75, "pitch_angle_deg": 70, "outer_transverse_module_mm": 40,
                            "face_width_mm": 240, "mean_spiral_angle_deg": 35, "hand": "right",
                            "pressure_angle_deg": 20},
                   "tool": {"radius_mm": 8}, "cut": {"flanks": ["concave"], "depth_levels": 3, "steps": 7}}
        path = self.dir / "split.json"
        path.write_text(json.dumps(request))
        done = self.run_cli("--json", "split-trajectory", str(path), "--levels", "2")
        self.assertEqual(done.returncode, 0, done.stderr)
        answer = json.loads(done.stdout)
        self.assertEqual([(p["flank"], p["level"], len(p["points"])) for p in answer["passes"]],
                         [("concave", 0, 7), ("concave", 1, 7)])
        self.assertNotIn("nc_program", answer)

    def test_split_trajectory_refusals(self) -> None:
        self.assert_server_refused("tool.radius_mm", "split-trajectory", "--teeth", "75", "--pitch-angle-deg", "70",
                                   "--module-mm", "40", "--face-width-mm", "240", "--spiral-angle-deg", "35",
                                   "--hand", "right", "--pressure-angle-deg", "20", "--tool-radius-mm", "20")
        self.assert_server_refused("gear.pitch_angle_deg", "split-trajectory", "--teeth", "75")
        done = self.run_cli("split-trajectory", "--steps", "many")
        self.assertEqual(done.returncode, 1, done.stderr)
        self.assertIn("--steps takes an integer", done.stderr)

    def test_replay_with_changed_option(self) -> None:
        job = self.submit()
        done = self.run_cli("--json", "replay", str(job["id"]), "--set", "solver=lsq-plain")
        self.assertIn(done.returncode, (0, 5), done.stderr)
        replay = json.loads(done.stdout)
        self.assertEqual(replay["parent_job_id"], job["id"])
        self.assertEqual(replay["result"]["solver"], "lsq-plain")
        refused = self.run_cli("replay", str(job["id"]), "--set", "max_num_iterations=-5")
        self.assertEqual(refused.returncode, 3, refused.stderr)

    def test_batch_over_folder(self) -> None:
        folder = self.dir / "parts"
        folder.mkdir(exist_ok=True)
        shutil.copy(EXAMPLES / "measurement.csv", folder / "part01.csv")
        shutil.copy(EXAMPLES / "measurement.json", folder / "part02.json")
        grid = read_csv_grid(str(EXAMPLES / "measurement.csv"))
        grid[1][1] = 2.5
        (folder / "part03.json").write_text(json.dumps({"deviations_um": grid}))
        (folder / "notes.txt").write_text("ignored")
        done = self.run_cli("batch", str(EXAMPLES / "request.json"), str(folder), "--poll-ms", "100")
        self.assertIn(done.returncode, (0, 5), done.stderr)
        self.assertIn("3 done, 0 failed of 3", done.stdout)
        for name in ("part01.csv", "part02.json", "part03.json"):
            self.assertIn(name, done.stdout)
        (folder / "part04.csv").write_text("1,2,3\n")
        invalid = self.run_cli("batch", str(EXAMPLES / "request.json"), str(folder))
        self.assertEqual(invalid.returncode, 4)
        self.assertIn("part04.csv: line 1", invalid.stderr)

    def test_simulate_and_closed_loop(self) -> None:
        out = self.dir / "simulated.csv"
        done = self.run_cli("simulate", str(EXAMPLES / "scenario.json"), "--csv", str(out), "--seed", "3")
        self.assertEqual(done.returncode, 0, done.stderr)
        self.assertIn("simulated measurement", done.stdout)
        self.assertEqual(len(read_csv_grid(str(out))), 5)
        # The simulated grid is itself a valid measurement file for submit.
        again = self.run_cli("--json", "submit", str(EXAMPLES / "request.json"), str(out))
        self.assertIn(again.returncode, (0, 5), again.stderr)

        loop = self.run_cli("closed-loop", str(EXAMPLES / "scenario.json"), "--corrections", "2", "--store")
        self.assertEqual(loop.returncode, 0, loop.stderr)
        self.assertIn("true rms", loop.stdout)
        as_json = json.loads(self.run_cli("--json", "closed-loop", str(EXAMPLES / "scenario.json"),
                                          "--corrections", "2").stdout)
        self.assertGreaterEqual(len(as_json["iterations"]), 2)

    def test_settings_from_links_the_next_part(self) -> None:
        first = self.submit()
        done = self.run_cli("--json", "submit", str(EXAMPLES / "request.json"), str(EXAMPLES / "measurement.json"),
                            "--settings-from", str(first["id"]))
        self.assertIn(done.returncode, (0, 5), done.stderr)
        second = json.loads(done.stdout)
        self.assertEqual(second["settings_source_job_id"], first["id"])
        stored = json.loads(self.run_cli("--json", "show", str(second["id"])).stdout)
        self.assertEqual(stored["request"]["settings"], first["result"]["settings"])
        lineage = [j["id"] for j in json.loads(self.run_cli("--json", "list", "--limit", "100").stdout)["jobs"]
                   if j.get("settings_source_job_id") == first["id"]]
        self.assertIn(second["id"], lineage)
        missing = self.run_cli("submit", str(EXAMPLES / "request.json"), str(EXAMPLES / "measurement.csv"),
                               "--settings-from", "999999")
        self.assertEqual(missing.returncode, 3)

    def test_nominal_settings_grind_the_involute(self) -> None:
        settings = self.dir / "nominal.json"
        done = self.run_cli("nominal", str(EXAMPLES / "request.json"), "--settings-out", str(settings))
        self.assertEqual(done.returncode, 0, done.stderr)
        self.assertIn("roll range", done.stdout)
        self.assertEqual(sorted(json.loads(settings.read_text())["axes"]), ["A", "B", "C", "X", "Y", "Z"])
        grid_csv = self.dir / "nominal_grid.csv"
        evaluated = self.run_cli("evaluate", str(EXAMPLES / "request.json"), "--settings", str(settings), "--csv",
                                 str(grid_csv))
        self.assertEqual(evaluated.returncode, 0, evaluated.stderr)
        self.assertNotIn("-0.00", evaluated.stdout)
        for row in read_csv_grid(str(grid_csv)):
            for value in row:
                if value is not None:
                    self.assertLess(abs(value), 1e-3)

    def test_shaving_target_summary_table_and_csv(self) -> None:
        grid_csv = self.dir / "shaving_target.csv"
        done = self.run_cli("shaving-target", str(EXAMPLES / "shaving.json"), "--csv", str(grid_csv))
        self.assertEqual(done.returncode, 0, done.stderr)
        for words in ("crossed-axes angle 5.090 deg", "contact-line length 75.342 mm",
                      "fixed wheel 355.78 mm", "traversing wheel 336.97 mm", "36 of 45 grid points",
                      "outside the work flank: (1,1)", "cutter target"):
            self.assertIn(words, done.stdout)
        grid = read_csv_grid(str(grid_csv))
        self.assertEqual(grid[0], [None] * 9)
        values = [v for row in grid[1:] for v in row]
        self.assertEqual(max(values), 0.0)
        # stock = delta_s - max(delta_s): row 1, column 9 = 8.94 - 12.29 (certified, +-0.05 um each).
        self.assertAlmostEqual(grid[1][8], 8.936 - 12.289, delta=0.01)
        as_json = self.run_cli("--json", "shaving-target", str(EXAMPLES / "shaving.json"), "--grid", "base")
        self.assertEqual(as_json.returncode, 0, as_json.stderr)
        self.assertIn("base_um", json.loads(as_json.stdout))
        bad = self.dir / "shaving_bad.json"
        request = json.loads((EXAMPLES / "shaving.json").read_text())
        request["centre_distance_mm"] = 400
        bad.write_text(json.dumps(request))
        self.assert_server_refused("centre_distance_mm", "shaving-target", str(bad))
        done = self.run_cli("shaving-target", str(EXAMPLES / "shaving.json"), "--grid", "other")
        self.assertEqual(done.returncode, 1)

    def test_report_is_self_contained(self) -> None:
        job = self.submit()
        out = self.dir / "job.html"
        done = self.run_cli("report", str(job["id"]), "-o", str(out))
        self.assertEqual(done.returncode, 0, done.stderr)
        html = out.read_text()
        self.assertIn("window.GEARLOOP_REPORT", html)
        self.assertIn("GearloopPlots", html)
        self.assertNotIn('src="/static', html)
        self.assertNotIn('href="/static', html)
        self.assertIn(f'"id":{job["id"]}', html)
        stdout = self.run_cli("report", str(job["id"]))
        self.assertEqual(stdout.stdout, html)


    # --- measuring-machine files (issue 15, METROLOGY.md) -----------------------------------------

    def sample_setup(self) -> Path:
        """The sample gear of shared/formats/README.md as a request file (with a wheel, for correct)."""
        path = self.dir / "sample_setup.json"
        path.write_text(json.dumps(SAMPLE_SETUP))
        return path

    def test_import_prints_the_grid_figures_and_classes(self) -> None:
        setup = str(self.sample_setup())
        csv_out = self.dir / "imported.csv"
        human = self.run_cli("import", str(SAMPLES / "sample_topography.mka"), "--setup", setup, "--csv", str(csv_out))
        self.assertEqual(human.returncode, 0, human.stderr)
        self.assertIn("row 1 root", human.stdout)
        self.assertIn("f_Ha mean (slope)", human.stdout)
        self.assertRegex(human.stdout, r"overall class\s+6")
        grid = read_csv_grid(str(csv_out))
        self.assertAlmostEqual(grid[0][0], -11.5, places=2)
        done = self.run_cli("--json", "import", str(SAMPLES / "sample_topography.gde.xml"), "--setup", setup)
        self.assertEqual(done.returncode, 0, done.stderr)
        answer = json.loads(done.stdout)
        self.assertEqual(answer["classes"]["overall"], 6)
        self.assertAlmostEqual(answer["deviations_um"][0][0], grid[0][0], places=2)
        # A Latin-1 export of the same file (umlauts in the header labels; Greek letters become ?)
        # reads the same.
        latin1 = self.dir / "latin1.mka"
        latin1.write_bytes((SAMPLES / "sample_topography.mka").read_text(encoding="utf-8-sig").encode("latin-1", errors="replace"))
        again = self.run_cli("--json", "import", str(latin1), "--setup", setup)
        self.assertEqual(again.returncode, 0, again.stderr)
        self.assertEqual(json.loads(again.stdout)["deviations_um"], json.loads(
            self.run_cli("--json", "import", str(SAMPLES / "sample_topography.mka"), "--setup", setup).stdout)[
            "deviations_um"])

    def test_import_refusals(self) -> None:
        setup = str(self.sample_setup())
        broken = self.dir / "broken.mka"
        text = (SAMPLES / "sample_topography.mka").read_text(encoding="utf-8-sig")
        broken.write_text(text.replace("-16.458", "-16,458", 1), encoding="utf-8")
        self.assert_server_refused("422 invalid_file at content: file:line ", "import", str(broken), "--setup", setup)
        self.assertEqual(self.run_cli("import", str(broken)).returncode, 1)                   # no --setup
        self.assertEqual(self.run_cli("import", str(self.dir / "x.txt"), "--setup", setup).returncode, 1)
        self.assertEqual(self.run_cli("import", str(self.dir / "nope.mka"), "--setup", setup).returncode, 4)

    def test_correct_from_a_measurement_file_and_export_gde(self) -> None:
        setup = str(self.sample_setup())
        done = self.run_cli("--json", "correct", setup, "--measurement-file", str(SAMPLES / "sample_topography.mka"))
        self.assertIn(done.returncode, (0, 5), done.stderr)
        job = json.loads(done.stdout)
        self.assertEqual(job["result"]["iso1328"]["measured"]["classes"]["overall"], 6)
        self.assertEqual(job["result"]["measurement_file"]["format"], "mka")
        human = self.run_cli("show", str(job["id"]))
        self.assertEqual(human.returncode, 0, human.stderr)
        self.assertIn("ISO 1328-1 class     6 measured", human.stdout)

        exported = self.dir / "job.gde.xml"
        done = self.run_cli("export", str(job["id"]), "--format", "gde", "-o", str(exported))
        self.assertEqual(done.returncode, 0, done.stderr)
        self.assertIn('kind="predicted"', exported.read_text())
        back = self.run_cli("--json", "import", str(exported), "--setup", setup)
        self.assertEqual(back.returncode, 0, back.stderr)
        imported = json.loads(back.stdout)["deviations_um"]
        for row, stored in zip(imported, job["result"]["measured_um"]):
            for a, b in zip(row, stored):
                self.assertAlmostEqual(a, b, delta=0.001)
        stdout = self.run_cli("export", str(job["id"]), "--format", "gde")
        self.assertEqual(stdout.returncode, 0)
        self.assertEqual(stdout.stdout, exported.read_text())
        self.assertEqual(self.run_cli("export", str(job["id"])).returncode, 1)
        self.assert_server_refused("404 not_found", "export", "987654", "--format", "gde")
        self.assertEqual(self.run_cli("correct", setup).returncode, 1)   # no --measurement-file

    def test_settings_listing_as_table_csv_and_nc(self) -> None:
        job = self.submit()
        table = self.run_cli("settings", str(job["id"]))
        self.assertEqual(table.returncode, 0, table.stderr)
        self.assertIn("gearloop settings listing 1, job %d" % job["id"], table.stdout)
        self.assertIn("axis motion over the roll range", table.stdout)
        out = self.dir / "settings.csv"
        done = self.run_cli("settings", str(job["id"]), "--format", "csv", "--samples", "5", "-o", str(out))
        self.assertEqual(done.returncode, 0, done.stderr)
        lines = out.read_text().strip().split("\n")
        self.assertEqual(lines[0], "record,block,power,roll_rad,unit,absolute,change,change_unit")
        records = [line.split(",") for line in lines[1:]]
        settings, delta = job["result"]["settings"]["axes"], job["result"]["delta"]["axes"]
        for record, axis, power, _, unit, absolute, change, _ in records:
            if record == "coefficient" and axis in ("X", "Y", "Z"):
                self.assertAlmostEqual(float(absolute), settings[axis][int(power)], delta=1e-9)
                self.assertAlmostEqual(float(change), delta[axis][int(power)], delta=1e-9)
        motion = [r for r in records if r[0] == "motion"]
        self.assertEqual(len(motion), 6 * 5)
        # The ends of the roll range are sampled as the result states its motion.
        z = [r for r in motion if r[1] == "Z"]
        axis_motion = job["result"]["axis_motion"]
        self.assertAlmostEqual(float(z[0][3]), axis_motion["roll_rad"][0], delta=1e-9)
        self.assertAlmostEqual(float(z[0][6]), axis_motion["axes"]["Z"]["change_um"][0], delta=1e-6)
        self.assertAlmostEqual(float(z[-1][6]), axis_motion["axes"]["Z"]["change_um"][-1], delta=1e-6)
        nc = self.run_cli("settings", str(job["id"]), "--format", "nc")
        self.assertEqual(nc.returncode, 0, nc.stderr)
        x0 = [line for line in nc.stdout.splitlines() if line.startswith("X_A0 = ")]
        self.assertEqual(len(x0), 1)
        self.assertAlmostEqual(float(x0[0].split()[2]), settings["X"][0], delta=1e-9)
        self.assertEqual(self.run_cli("settings", str(job["id"]), "--format", "xml").returncode, 1)
        self.assertEqual(self.run_cli("settings", str(job["id"]), "--samples", "1").returncode, 1)
        self.assert_server_refused("404 not_found", "settings", "987654")

    def test_tolerance_verdict_and_exit_code(self) -> None:
        request = json.loads((EXAMPLES / "request.json").read_text())
        request["tolerance"] = {"rms_um": 0.01, "max_um": 0.02}
        tight = self.dir / "tight.json"
        tight.write_text(json.dumps(request))
        done = self.run_cli("submit", str(tight), str(EXAMPLES / "measurement.csv"))
        self.assertEqual(done.returncode, 5, done.stderr)
        self.assertIn("tolerance            rms 0.01 um, max 0.02 um", done.stdout)
        self.assertIn("verdict predicted    FAIL  (misses rms_um, max_um)", done.stdout)
        as_json = json.loads(self.run_cli("--json", "submit", str(tight), str(EXAMPLES / "measurement.csv")).stdout)
        self.assertIn(as_json["status"], ("target_partly_reachable", "not_converged"))
        request["tolerance"] = {"rms_um": 900}
        loose = self.dir / "loose.json"
        loose.write_text(json.dumps(request))
        done = self.run_cli("submit", str(loose), str(EXAMPLES / "measurement.csv"))
        self.assertEqual(done.returncode, 0, done.stdout)
        self.assertIn("verdict measured     PASS", done.stdout)
        self.assertIn("verdict predicted    PASS", done.stdout)
        folder = self.dir / "tolerance-batch"
        folder.mkdir()
        shutil.copy(EXAMPLES / "measurement.csv", folder / "part1.csv")
        batch = self.run_cli("batch", str(tight), str(folder))
        self.assertEqual(batch.returncode, 5, batch.stderr)
        self.assertIn("verdict (measured/predicted)", batch.stdout)
        self.assertIn("/FAIL", batch.stdout)

    def test_lineage_lists_the_settings_chain(self) -> None:
        first = self.submit()
        second = self.submit("--settings-from", str(first["id"]))
        done = self.run_cli("lineage", str(second["id"]))
        self.assertEqual(done.returncode, 0, done.stderr)
        rows = [line.split() for line in done.stdout.splitlines()[1:-1]]
        self.assertEqual([r[0] for r in rows], [str(first["id"]), str(second["id"]) + "*"])
        self.assertEqual(rows[1][5], str(first["id"]))   # "from": ground with the first job's settings
        self.assertIn("2 jobs in the lineage of job %d" % second["id"], done.stdout)
        as_json = json.loads(self.run_cli("--json", "lineage", str(first["id"])).stdout)
        self.assertEqual([j["id"] for j in as_json["jobs"]], [first["id"], second["id"]])
        self.assert_server_refused("404 not_found", "lineage", "987654")
        self.assertEqual(self.run_cli("lineage", "x").returncode, 1)

    def test_bevel_sensitivity_ranks_the_axes(self) -> None:
        done = self.run_cli("bevel-sensitivity", "--side", "convex", "--top", "4")
        self.assertEqual(done.returncode, 0, done.stderr)
        answer = json.loads(self.run_cli("--json", "bevel-sensitivity", "--side", "convex").stdout)
        lines = done.stdout.splitlines()
        offsets = lines[2:2 + len(answer["offset_ranking"])]
        self.assertEqual([line.split()[1] for line in offsets], answer["offset_ranking"])
        first = next(o for o in answer["offsets"] if o["axis"] == answer["offset_ranking"][0])
        self.assertAlmostEqual(float(offsets[0].split()[4]), first["max_abs_um"], delta=0.001)
        coefficients = lines[lines.index("") + 3:]
        self.assertEqual([line.split()[1] for line in coefficients], answer["coefficient_ranking"][:4])
        bad = self.run_cli("bevel-sensitivity", "--linear-error-mm", "-1")
        self.assertEqual(bad.returncode, 3, bad.stderr)
        self.assertIn("errors.linear_error_mm", bad.stderr)

    def test_reach_of_the_example_target(self) -> None:
        done = self.run_cli("reach", str(EXAMPLES / "request.json"))
        answer = json.loads(self.run_cli("--json", "reach", str(EXAMPLES / "request.json")).stdout)
        share = answer["components"][0]["reachable_share"]
        # The README's lead crowning on a fixed wheel: only part of it can be made.
        self.assertEqual(done.returncode, 5 if share < 0.99 else 0, done.stderr)
        row = next(line for line in done.stdout.splitlines() if line.startswith("lead_crowning 4 um"))
        self.assertEqual(row.split()[-2], "%.1f" % (100 * share))
        self.assertAlmostEqual(float(row.split()[3]), answer["components"][0]["target_rms_um"], delta=0.001)
        # Every order is open by default: no row of its own for every axis at order 6; held to
        # the cubic terms, the row is there.
        self.assertNotIn("every axis to order 6", done.stdout)
        setup = json.loads((EXAMPLES / "request.json").read_text())
        setup["options"] = {"default_max_order": 3}
        held = self.dir / "reach-held.json"
        held.write_text(json.dumps(setup))
        self.assertIn("all together, every axis to order 6", self.run_cli("reach", str(held)).stdout)
        # Under the row, the remedy the server computed and what else it tried.
        remedy = answer["components"][0]["remedy"]
        lines = done.stdout.splitlines()
        under = lines[lines.index(row) + 1]
        if remedy is None:
            self.assertFalse(under.startswith("  -> "), under)
        else:
            self.assertTrue(under.startswith("  -> "), under)
            if remedy["kind"] == "wheel_profile":
                self.assertIn("%.1f %%" % (100 * remedy["wheel_profile"]["reachable_share"]), under)
            if remedy["higher_order"] is not None:
                self.assertIn("%s to order %d" % (remedy["higher_order"]["axis"], remedy["higher_order"]["order"]),
                              under)
        self.assert_server_refused("target.modifications", "reach", str(self.sample_setup()))

    def test_trace_stored_shown_and_filtered(self) -> None:
        setup = str(self.sample_setup())
        serial = "S-%d" % os.getpid()
        done = self.run_cli("--json", "correct", setup, "--measurement-file", str(SAMPLES / "sample_topography.mka"),
                            "--part-number", "4711-A", "--serial", serial, "--teeth", "1,10,19",
                            "--measured-at", "2026-11-22T07:45:00Z", "--machine-id", "RZ260-2")
        self.assertIn(done.returncode, (0, 5), done.stderr)
        job = json.loads(done.stdout)
        self.assertEqual(job["trace"], {"part_number": "4711-A", "serial": serial, "teeth": [1, 10, 19],
                                        "measured_at": "2026-11-22T07:45:00Z",
                                        "file_name": "sample_topography.mka", "machine_id": "RZ260-2"})
        shown = self.run_cli("show", str(job["id"]))
        self.assertEqual(shown.returncode, 0, shown.stderr)
        self.assertIn("part 4711-A, serial " + serial + ", teeth 1 10 19, measured 2026-11-22T07:45:00Z, "
                      "file sample_topography.mka, machine RZ260-2", shown.stdout)
        listed = self.run_cli("list", "--serial", serial, "--tooth", "10")
        self.assertEqual(listed.returncode, 0, listed.stderr)
        self.assertIn("4711-A/" + serial, listed.stdout)
        self.assertIn("1 of 1 jobs", listed.stdout)
        none = self.run_cli("list", "--serial", serial, "--tooth", "2")
        self.assertIn("0 of 0 jobs", none.stdout)
        self.assert_server_refused("query.tooth", "list", "--tooth", "0")
        self.assert_server_refused("trace.measured_at", "submit", str(EXAMPLES / "request.json"),
                                   str(EXAMPLES / "measurement.csv"), "--measured-at", "tuesday")
        bad = self.run_cli("submit", str(EXAMPLES / "request.json"), str(EXAMPLES / "measurement.csv"),
                           "--teeth", "1,x")
        self.assertEqual(bad.returncode, 1)
        self.assertIn("--teeth", bad.stderr)

class CannedLoopServer(BaseHTTPRequestHandler):
    """Answers every closed-loop request with the loop in `answer` (a server whose solver made
    the parts worse, which the real one cannot be made to do on demand)."""
    answer: dict = {}

    def do_POST(self) -> None:  # noqa: N802 (http.server's name)
        self.rfile.read(int(self.headers.get("Content-Length", "0")))
        self.send_answer()

    def send_answer(self) -> None:
        body = json.dumps(self.answer).encode()
        self.send_response(200)
        self.send_header("Content-Type", "application/json")
        self.send_header("Content-Length", str(len(body)))
        self.end_headers()
        self.wfile.write(body)

    def log_message(self, *args) -> None:
        pass


class CannedJobServer(CannedLoopServer):
    """Answers every GET with the job in `answer` (a stored job as an older server kept it)."""

    def do_GET(self) -> None:  # noqa: N802 (http.server's name)
        self.send_answer()


def run_against_canned(handler: type, answer: dict, *args: str) -> subprocess.CompletedProcess:
    """Runs the CLI against a server whose handler answers with `answer`."""
    handler.answer = answer
    server = ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        return subprocess.run([CLI, "--server", "http://127.0.0.1:%d" % server.server_address[1], *args],
                              capture_output=True, text=True, timeout=60)
    finally:
        server.shutdown()
        server.server_close()


class CliClosedLoopExitTest(unittest.TestCase):
    def run_loop(self, true_rms: list) -> subprocess.CompletedProcess:
        return run_against_canned(CannedLoopServer, {
            "completed": True, "message": "", "hidden_errors": {},
            "iterations": [{"part": i, "true_rms_um": v, "true_max_um": v, "measured_rms_um": v}
                           for i, v in enumerate(true_rms)]}, "closed-loop", str(EXAMPLES / "scenario.json"))

    def test_a_diverged_loop_exits_5_and_says_so(self) -> None:
        diverged = self.run_loop([4.5, 90.0, 1700.0])
        self.assertEqual(diverged.returncode, 5, diverged.stderr)
        self.assertIn("the loop diverged: part 2 deviates 1700.000 um rms from the target, part 0 4.500 um",
                      diverged.stderr)
        improved = self.run_loop([4.5, 0.06, 0.07])
        self.assertEqual(improved.returncode, 0, improved.stderr)
        self.assertNotIn("diverged", improved.stderr)


class CliTokenTest(unittest.TestCase):
    def test_token_is_sent_and_refusals_are_api_errors(self) -> None:
        with tempfile.TemporaryDirectory(prefix="gearloop-tokens-") as folder:
            tokens = write_token_file(folder, "reader-secret", "writer-secret")
            with RunningServer(extra_args=["--token-file", tokens]) as server:
                def run(*args: str, env_token: str = "") -> subprocess.CompletedProcess:
                    env = dict(os.environ)
                    env.pop("GEARLOOP_TOKEN", None)
                    if env_token:
                        env["GEARLOOP_TOKEN"] = env_token
                    return subprocess.run([CLI, "--server", server.url, *args], capture_output=True, text=True,
                                          timeout=120, env=env)
                request, measurement = str(EXAMPLES / "request.json"), str(EXAMPLES / "measurement.csv")
                anonymous = run("list")
                self.assertEqual(anonymous.returncode, 3)
                self.assertIn("401 unauthorized", anonymous.stderr)
                self.assertEqual(run("--token", "reader-secret", "list").returncode, 0)
                reader = run("--token", "reader-secret", "submit", request, measurement)
                self.assertEqual(reader.returncode, 3)
                self.assertIn("403 forbidden", reader.stderr)
                writer = run("submit", request, measurement, env_token="writer-secret")
                self.assertIn(writer.returncode, (0, 5), writer.stderr)


if __name__ == "__main__":
    unittest.main()
