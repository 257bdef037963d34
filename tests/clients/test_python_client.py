"""Tests of clients/python/gearloop_client.py against a real gearloop-server (server_fixture)."""

from __future__ import annotations

import copy
import os
import unittest

from gearloop_client import (BEVEL_MACHINE_KIND, Client, GearloopApiError, GearloopTransportError,
                             format_csv_grid, read_csv_grid, read_machine_file, read_measurement_file)
from server_fixture import EXAMPLES, REPO, RunningServer, example_json, free_port, write_token_file

# The sample files of shared/formats (copies kept in tests/formats/data) and their gear.
SAMPLES = REPO / "tests" / "formats" / "data"
SAMPLE_GEAR = {"teeth": 31, "normal_module_mm": 4.5, "normal_pressure_angle_deg": 20, "helix_angle_deg": 20,
               "hand": "right", "face_width_mm": 40, "tip_radius_mm": 78.726, "root_radius_mm": 68.601}


class PythonClientTest(unittest.TestCase):
    server: RunningServer
    client: Client

    @classmethod
    def setUpClass(cls) -> None:
        cls.server = RunningServer().__enter__()
        cls.client = Client(cls.server.url, timeout=60)
        cls.request = example_json("request.json")
        cls.request["measurement"] = {"deviations_um": read_csv_grid(str(EXAMPLES / "measurement.csv"))}

    @classmethod
    def tearDownClass(cls) -> None:
        cls.server.__exit__(None, None, None)

    def test_health_and_metrics(self) -> None:
        self.assertEqual(self.client.health()["status"], "ok")
        self.assertIn("gearloop", self.client.metrics())

    def test_nominal_evaluate_sensitivity(self) -> None:
        setup = {k: self.request[k] for k in ("gear", "wheel", "machine", "grid", "flank")}
        nominal = self.client.nominal(setup)
        self.assertEqual(sorted(nominal["settings"]["axes"]), ["A", "B", "C", "X", "Y", "Z"])
        evaluated = self.client.evaluate(dict(setup, settings=nominal["settings"]))
        grid = evaluated["deviations_um"]
        self.assertEqual((len(grid), len(grid[0])), (5, 9))
        # Nominal settings grind the exact involute helicoid: zero wherever the wheel reaches.
        for row in grid:
            for value in row:
                if value is not None:
                    self.assertAlmostEqual(value, 0.0, places=3)
        sens = self.client.sensitivity(dict(setup, settings=nominal["settings"]))
        self.assertEqual(len(sens["matrix"]), 45)
        self.assertEqual(len(sens["matrix"][0]), 45)
        self.assertGreater(sens["rank"], 0)

    def test_correction_is_stored_listed_and_replayed(self) -> None:
        job = self.client.create_correction(self.request)
        self.assertIsInstance(job["id"], int)
        result = job["result"]
        self.assertIn(result["status"], ("converged", "not_converged"))
        self.assertEqual(len(result["predicted_residual_um"]), 5)
        self.assertLess(result["residual_rms_um"], result["initial_rms_um"])
        # The exact-model search: what it did, and its two exact predictions (um, None when not computed).
        search = result["exact_search"]
        self.assertRegex(search["outcome"], r"^(not run|taken|kept the regularised answer): ")
        for key in ("regularised_predicted_rms_um", "searched_predicted_rms_um"):
            self.assertTrue(search[key] is None or isinstance(search[key], float), key)

        stored = self.client.get_correction(job["id"])
        self.assertEqual(stored["id"], job["id"])
        self.assertEqual(stored["request"]["measurement"], self.request["measurement"])
        self.assertEqual(stored["result"]["exact_search"], search)
        listed = self.client.list_corrections(limit=5)
        self.assertIn(job["id"], [j["id"] for j in listed["jobs"]])
        self.assertEqual(listed["jobs"][0]["id"], max(j["id"] for j in listed["jobs"]))  # newest first
        only = self.client.list_corrections(limit=50, kind="replay")
        self.assertTrue(all(j["kind"] == "replay" for j in only["jobs"]))

        replay = self.client.replay(job["id"], options={"solver": "lsq-plain"})
        self.assertEqual(replay["parent_job_id"], job["id"])
        self.assertEqual(replay["kind"], "replay")
        self.assertEqual(replay["result"]["solver"], "lsq-plain")
        self.assertEqual(replay["result"]["exact_search"]["outcome"], "")  # lsq-plain has no search
        lineage = self.client.lineage(replay["id"])
        self.assertIn(replay["id"], [j["id"] for j in lineage["jobs"]])

    def test_trace_tolerance_and_settings_listing(self) -> None:
        request = dict(self.request)
        request["trace"] = {"part_number": "PY-1", "serial": "S-%d" % os.getpid(), "teeth": [4]}
        request["tolerance"] = {"rms_um": 1000}
        job = self.client.create_correction(request)
        self.assertEqual(job["trace"]["part_number"], "PY-1")
        self.assertEqual(job["result"]["verdict"]["predicted"]["verdict"], "PASS")
        found = self.client.list_corrections(serial=request["trace"]["serial"], tooth=4)
        self.assertEqual([j["id"] for j in found["jobs"]], [job["id"]])
        csv_text = self.client.correction_settings(job["id"], samples=3)
        rows = [line.split(",") for line in csv_text.strip().split("\n")]
        self.assertEqual(rows[0][0], "record")
        x0 = next(r for r in rows if r[:3] == ["coefficient", "X", "0"])
        self.assertAlmostEqual(float(x0[5]), job["result"]["settings"]["axes"]["X"][0], delta=1e-9)
        self.assertEqual(len([r for r in rows if r[0] == "motion" and r[1] == "X"]), 3)
        self.assertIn("operationId: getCorrectionSettings", self.client.openapi_document())

    def test_api_error_carries_code_message_and_field(self) -> None:
        bad = copy.deepcopy(self.request)
        bad["measurement"]["deviations_um"][2][7] = "x"
        with self.assertRaises(GearloopApiError) as caught:
            self.client.create_correction(bad)
        self.assertEqual(caught.exception.status, 400)
        self.assertEqual(caught.exception.field, "measurement.deviations_um[2][7]")
        self.assertTrue(caught.exception.code)
        self.assertTrue(caught.exception.message)

        impossible = copy.deepcopy(self.request)
        impossible["gear"]["teeth"] = -3
        with self.assertRaises(GearloopApiError) as caught:
            self.client.create_correction(impossible)
        self.assertEqual(caught.exception.status, 422)
        self.assertEqual(caught.exception.code, "invalid_value")
        self.assertTrue(caught.exception.field.startswith("gear.teeth"), caught.exception.field)

        with self.assertRaises(GearloopApiError) as caught:
            self.client.get_correction(999999)
        self.assertEqual(caught.exception.status, 404)

    def test_shaving_cutter_target_and_a_correction_towards_it(self) -> None:
        shaving = example_json("shaving.json")
        answer = self.client.shaving_cutter_target(
            shaving["work_gear"], shaving["cutter"], diagonal_modification=shaving["diagonal_modification"],
            wheel_check=shaving["wheel_check"])
        self.assertAlmostEqual(answer["crossed_axes_angle_deg"], 5.09, places=9)
        self.assertAlmostEqual(answer["wheel_radius_min_mm"]["fixed"], 355.78, delta=5e-3)
        self.assertAlmostEqual(answer["contact_line_length_mm"], 75.342, delta=5e-4)
        # SHAVING.md §4, certified row 1 of the modified pinion (+-0.05 um).
        for got, want in zip(answer["delta_s_um"][1], [12.29, 7.46, 3.88, 1.59, 0.58, 0.87, 2.48, 5.20, 8.94]):
            self.assertAlmostEqual(got, want, delta=0.05)
        self.assertEqual(answer["outside_work_flank"], [[0, c] for c in range(9)])
        self.assertEqual(answer["stock_target_um"][0], [None] * 9)
        self.assertEqual(max(v for row in answer["stock_target_um"] for v in row if v is not None), 0.0)

        request = copy.deepcopy(self.request)
        request["target"] = {"shaving": shaving}
        job = self.client.create_correction(request)
        self.assertEqual(job["result"]["target_um"], answer["stock_target_um"])
        stored = self.client.get_correction(job["id"])["request"]["target"]
        self.assertEqual(stored["stock_target_um"], answer["stock_target_um"])

        with self.assertRaises(GearloopApiError) as caught:
            self.client.shaving_cutter_target(shaving["work_gear"], shaving["cutter"], centre_distance_mm=400)
        self.assertEqual(caught.exception.status, 422)
        self.assertEqual(caught.exception.field, "centre_distance_mm")

    def test_batch_runs_in_background(self) -> None:
        second = copy.deepcopy(self.request)
        second["measurement"]["deviations_um"][0][0] = 3.0
        broken = copy.deepcopy(self.request)
        broken["gear"]["normal_module_mm"] = -1
        created = self.client.create_batch([self.request, second, broken])
        batch = self.client.wait_batch(created["id"], timeout=240)
        self.assertEqual(batch["total"], 3)
        self.assertEqual(batch["done"], 2)
        self.assertEqual(batch["failed"], 1)
        failed = [item for item in batch["items"] if item["state"] == "failed"]
        self.assertEqual(failed[0]["index"], 2)
        self.assertIn("normal_module_mm", failed[0]["error"]["field"])

    def test_simulations(self) -> None:
        scenario = example_json("scenario.json")
        # The measurement takes no closed-loop keys (strict input, issue 17).
        measurement_scenario = {k: v for k, v in scenario.items() if k != "corrections"}
        simulated = self.client.simulate_measurement(measurement_scenario)
        grid = simulated["measurement"]["deviations_um"]
        self.assertEqual((len(grid), len(grid[0])), (5, 9))
        loop = self.client.simulate_closed_loop(dict(scenario, corrections=2))
        iterations = loop["iterations"]
        self.assertGreaterEqual(len(iterations), 2)
        self.assertLess(iterations[-1]["true_rms_um"], iterations[0]["true_rms_um"])

    def test_transport_error_when_no_server(self) -> None:
        client = Client(f"http://127.0.0.1:{free_port()}", timeout=5)
        with self.assertRaises(GearloopTransportError):
            client.health()
        with self.assertRaises(ValueError):
            Client("127.0.0.1:8080")


    def test_measuring_machine_files(self) -> None:
        mka = read_machine_file(str(SAMPLES / "sample_topography.mka"))
        gde = read_machine_file(str(SAMPLES / "sample_topography.gde.xml"))
        self.assertEqual((mka["format"], gde["format"]), ("mka", "gde"))
        a = self.client.import_measurement(SAMPLE_GEAR, mka)
        b = self.client.import_measurement(SAMPLE_GEAR, gde, flank="right")
        for row_a, row_b in zip(a["deviations_um"], b["deviations_um"]):
            for x, y in zip(row_a, row_b):
                self.assertAlmostEqual(x, y, delta=0.001)
        self.assertEqual(a["classes"], b["classes"])
        self.assertEqual(a["classes"]["overall"], 6)
        self.assertAlmostEqual(a["figures"]["Fb_max_abs"], 10.0, delta=0.01)
        left = self.client.import_measurement(SAMPLE_GEAR, mka, flank="left", tooth=1)
        self.assertAlmostEqual(left["figures"]["fHa_mean_grid"], -3.0, delta=0.01)

        broken = dict(mka, content=mka["content"].replace("-16.458", "-16,458", 1))
        with self.assertRaises(GearloopApiError) as refused:
            self.client.import_measurement(SAMPLE_GEAR, broken)
        self.assertEqual((refused.exception.status, refused.exception.code), (422, "invalid_file"))
        self.assertIn("file:line ", refused.exception.message)
        with self.assertRaises(ValueError):
            read_machine_file(str(SAMPLES / "sample_topography.mka"), format="csv")

        request = {"gear": SAMPLE_GEAR, "wheel": {"radius_mm": 350}, "flank": "right"}
        job = self.client.create_correction_from_file(request, mka)
        iso = job["result"]["iso1328"]
        self.assertEqual(iso["measured"]["classes"]["overall"], 6)
        self.assertLessEqual(iso["predicted"]["classes"]["overall"], 6)
        xml = self.client.export_correction(job["id"])
        self.assertIn('kind="measured"', xml)
        back = self.client.import_measurement(SAMPLE_GEAR, {"format": "gde", "content": xml})
        for row, stored in zip(back["deviations_um"], job["result"]["measured_um"]):
            for x, y in zip(row, stored):
                self.assertAlmostEqual(x, y, delta=0.001)
        with self.assertRaises(GearloopApiError) as wrong:
            self.client.export_correction(job["id"], format="mka")
        self.assertEqual(wrong.exception.status, 422)

def grid_rms(grid) -> float:
    values = [v for row in grid for v in row if v is not None]
    return (sum(v * v for v in values) / len(values)) ** 0.5


class BevelClientTest(unittest.TestCase):
    """The bevel_* methods against the real server, on the published pinion of Tang 2011."""

    server: RunningServer
    client: Client
    job = {"side": "concave", "published": True}
    # Hidden axis errors of the erring free-form machine: B swing 0.003 deg, X 8 um, Y drifting.
    hidden = {"B_rad": [-0.003 * 3.141592653589793 / 180.0], "X_mm": [0.008], "Y_mm": [0.0, -0.02]}

    @classmethod
    def setUpClass(cls) -> None:
        cls.server = RunningServer().__enter__()
        cls.client = Client(cls.server.url, timeout=120)

    @classmethod
    def tearDownClass(cls) -> None:
        cls.server.__exit__(None, None, None)

    def test_conversion_degree_and_tolerance(self) -> None:
        converted = self.client.bevel_conversion(self.job, polynomial_degree=4)
        self.assertEqual(converted["degree"], 4)
        for axis in ("A_rad", "B_rad", "X_mm", "Y_mm", "Z_mm"):
            self.assertEqual(len(converted["motion"][axis]), 5, axis)
        self.assertEqual(len(converted["roll_range_deg"]), 2)
        self.assertLess(converted["flank_distance"]["max_um"], 10.0)
        # The tolerance picks the smallest degree that meets it.
        fitted = self.client.bevel_conversion(self.job, max_flank_distance_um=1.0)
        self.assertLessEqual(fitted["flank_distance"]["max_um"], 1.0)
        self.assertGreaterEqual(fitted["degree"], 2)

    def test_evaluate_converted_and_changed_motion(self) -> None:
        converted = self.client.bevel_conversion(self.job)
        evaluated = self.client.bevel_evaluate(self.job, converted["motion"])
        grid = evaluated["deviations_um"]
        self.assertEqual((len(grid), len(grid[0])), (evaluated["rows"], evaluated["columns"]))
        self.assertLess(grid_rms(grid), 1.0)  # the converted motion cuts the cradle flank
        self.assertEqual(self.client.bevel_evaluate(self.job)["deviations_um"], grid)  # default: converted
        moved = dict(converted["motion"])
        moved["X_mm"] = [moved["X_mm"][0] + 0.01] + moved["X_mm"][1:]
        self.assertGreater(grid_rms(self.client.bevel_evaluate(self.job, moved)["deviations_um"]), 1.0)

    def test_axis_sensitivity_ranks_axes(self) -> None:
        table = self.client.bevel_axis_sensitivity(self.job, linear_error_mm=0.01, angular_error_deg=0.01,
                                                   exact=False)
        self.assertEqual(sorted(table["offset_ranking"]), ["A", "B", "X", "Y", "Z"])
        self.assertEqual(len(table["offsets"]), 5)
        top = next(row for row in table["offsets"] if row["axis"] == table["offset_ranking"][0])
        self.assertGreater(top["rms_um"], 0.0)

    def test_measure_correct_recut(self) -> None:
        cmm = self.client.simulate_bevel_measurement(self.job, hidden_errors=self.hidden, noise_um=0.2, seed=5)
        self.assertEqual(cmm["machine_kind"], BEVEL_MACHINE_KIND)
        true_rms = grid_rms(cmm["true_deviations_um"])
        self.assertGreater(true_rms, 1.0)
        job = self.client.create_bevel_correction(self.job, cmm["measurement"],
                                                  options={"default_max_order": 2, "probe_noise_um": 0.2})
        self.assertIsInstance(job["id"], int)
        result = job["result"]
        self.assertEqual(result["machine_kind"], BEVEL_MACHINE_KIND)
        self.assertEqual(result["side"], "concave")
        self.assertIn(result["status"], ("converged", "not_converged"))
        self.assertEqual(len(result["motion"]["A_rad"]), len(result["delta"]["A_rad"]))
        # The same erring machine cuts the next pinion with the corrected motion.
        recut = self.client.simulate_bevel_measurement(self.job, motion=result["motion"], hidden_errors=self.hidden)
        self.assertLess(grid_rms(recut["true_deviations_um"]), 0.1 * true_rms)
        # A bevel job is stored, fetched and replayed like any other.
        stored = self.client.get_correction(job["id"])
        self.assertEqual(stored["machine_kind"], BEVEL_MACHINE_KIND)
        self.assertEqual(stored["flank"], "concave")
        replay = self.client.replay(job["id"], options={"default_max_order": 1})
        self.assertEqual(replay["parent_job_id"], job["id"])
        self.assertEqual(replay["result"]["machine_kind"], BEVEL_MACHINE_KIND)

    def test_closed_loop_stores_linked_jobs(self) -> None:
        loop = self.client.simulate_bevel_closed_loop(self.job, hidden_errors=self.hidden, noise_um=0.2, seed=11,
                                                      corrections=2, options={"default_max_order": 2}, store=True)
        self.assertEqual(loop["machine_kind"], BEVEL_MACHINE_KIND)
        self.assertTrue(loop["completed"])
        iterations = loop["iterations"]
        self.assertEqual(len(iterations), 3)
        self.assertLess(iterations[-1]["true_rms_um"], 0.1 * iterations[0]["true_rms_um"])
        self.assertIsNone(iterations[-1]["correction"])
        self.assertIn("A_rad", iterations[0]["motion"])
        second = self.client.get_correction(iterations[1]["job_id"])
        self.assertEqual(second["kind"], "closed_loop")
        self.assertEqual(second["settings_source_job_id"], iterations[0]["job_id"])

    def test_errors_carry_field_and_message(self) -> None:
        with self.assertRaises(GearloopApiError) as caught:
            self.client.bevel_conversion({"side": "sideways", "published": True})
        self.assertIn(caught.exception.status, (400, 422))
        self.assertEqual(caught.exception.field, "job.side")
        self.assertTrue(caught.exception.message)

        with self.assertRaises(GearloopApiError) as caught:
            self.client.bevel_conversion(self.job, polynomial_degree=40)
        self.assertEqual((caught.exception.status, caught.exception.code), (422, "invalid_value"))
        self.assertEqual(caught.exception.field, "options.polynomial_degree")

        with self.assertRaises(GearloopApiError) as caught:
            self.client.bevel_evaluate(self.job, {"A_rad": [0.0], "B_rad": [0.0]})
        self.assertEqual(caught.exception.status, 400)
        self.assertTrue(caught.exception.field.startswith("motion"), caught.exception.field)

        with self.assertRaises(GearloopApiError) as caught:
            self.client.bevel_axis_sensitivity(self.job, linear_error_mm=-1)
        self.assertEqual(caught.exception.status, 422)
        self.assertEqual(caught.exception.field, "errors.linear_error_mm")

        with self.assertRaises(GearloopApiError) as caught:
            self.client.create_bevel_correction(self.job, {"deviations_um": [[1.0, 2.0, 3.0]]})
        self.assertEqual(caught.exception.status, 400)
        self.assertTrue(caught.exception.field.startswith("measurement"), caught.exception.field)

        with self.assertRaises(GearloopApiError) as caught:
            self.client.simulate_bevel_measurement(self.job, noise_um=-1)
        self.assertEqual((caught.exception.status, caught.exception.field), (422, "noise_um"))

        with self.assertRaises(GearloopApiError) as caught:
            self.client.simulate_bevel_closed_loop(self.job, corrections=0)
        self.assertEqual((caught.exception.status, caught.exception.field), (422, "corrections"))


class SplitTrajectoryClientTest(unittest.TestCase):
    """split_trajectory and split_trajectory_nc against the real server, on the wheel of
    docs/split-bevel.md (z = 75, delta = 70 deg, m_et = 40 mm, beta_m = 35 deg right hand)."""

    server: RunningServer
    client: Client
    gear = {"teeth": 75, "pitch_angle_deg": 70, "outer_transverse_module_mm": 40, "face_width_mm": 240,
            "mean_spiral_angle_deg": 35, "hand": "right", "pressure_angle_deg": 20}
    tool = {"radius_mm": 8, "stock_mm": 0.2}

    @classmethod
    def setUpClass(cls) -> None:
        cls.server = RunningServer().__enter__()
        cls.client = Client(cls.server.url, timeout=120)

    @classmethod
    def tearDownClass(cls) -> None:
        cls.server.__exit__(None, None, None)

    def test_trajectory_job_and_nc_program(self) -> None:
        answer = self.client.split_trajectory(self.gear, self.tool,
                                              cut={"slot_index": 3, "depth_levels": 4, "steps": 5},
                                              machine={"pivot_length_mm": 300}, nc=True)
        self.assertAlmostEqual(answer["derived"]["base_radius_mm"], 1209.286851, places=5)
        self.assertEqual([(p["flank"], p["level"]) for p in answer["passes"]],
                         [("convex", j) for j in range(4)] + [("concave", j) for j in range(4)])
        first = answer["passes"][0]["points"][0]
        self.assertAlmostEqual(first["A_deg"], 17.3882, places=4)
        self.assertAlmostEqual(first["B_deg"], 11.2437, places=4)
        self.assertAlmostEqual(first["X_mm"], 1336.2082, places=4)
        nc = self.client.split_trajectory_nc(answer["job_id"])
        self.assertEqual(nc, answer["nc_program"])
        self.assertIn("G01 X1336.2082 Y-43.8387 Z-168.4312 A17.3882 B11.2437 F200.0\n", nc)
        job = self.client.get_correction(answer["job_id"])
        self.assertEqual((job["kind"], job["machine_kind"], job["flank"]),
                         ("split_trajectory", "head-head-5-axis-mill", "both"))
        self.assertEqual(job["result"]["passes"], answer["passes"])
        listed = self.client.list_corrections(kind="split_trajectory")
        self.assertIn(answer["job_id"], [j["id"] for j in listed["jobs"]])
        # Without nc the answer leaves the listing out; the job keeps it.
        lean = self.client.split_trajectory(self.gear, self.tool, cut={"flanks": ["concave"], "steps": 3})
        self.assertNotIn("nc_program", lean)
        self.assertTrue(self.client.split_trajectory_nc(lean["job_id"]).startswith("%\n(GEARLOOP SPLIT-BEVEL 1)\n"))

    def test_refusals_name_the_field(self) -> None:
        with self.assertRaises(GearloopApiError) as caught:
            self.client.split_trajectory(self.gear, {"radius_mm": 20})
        self.assertEqual((caught.exception.status, caught.exception.field), (422, "tool.radius_mm"))
        with self.assertRaises(GearloopApiError) as caught:
            self.client.split_trajectory(self.gear, self.tool, machine={"a_limits_deg": [-5, 5]})
        self.assertEqual((caught.exception.status, caught.exception.field), (422, "machine.a_limits_deg"))
        with self.assertRaises(GearloopApiError) as caught:
            self.client.split_trajectory_nc(987654)
        self.assertEqual(caught.exception.status, 404)


class TokenTest(unittest.TestCase):
    def test_bearer_token_roles(self) -> None:
        import tempfile
        with tempfile.TemporaryDirectory(prefix="gearloop-tokens-") as folder:
            tokens = write_token_file(folder, "reader-secret", "writer-secret")
            with RunningServer(extra_args=["--token-file", tokens]) as server:
                request = example_json("request.json")
                request["measurement"] = {"deviations_um": read_csv_grid(str(EXAMPLES / "measurement.csv"))}
                with self.assertRaises(GearloopApiError) as caught:
                    Client(server.url).list_corrections()
                self.assertEqual((caught.exception.status, caught.exception.code), (401, "unauthorized"))
                reader = Client(server.url, token="reader-secret")
                self.assertEqual(reader.list_corrections()["total"], 0)
                with self.assertRaises(GearloopApiError) as caught:
                    reader.create_correction(request)
                self.assertEqual(caught.exception.status, 403)
                job = Client(server.url, token="writer-secret").create_correction(request)
                self.assertEqual(reader.get_correction(job["id"])["id"], job["id"])


class CsvGridTest(unittest.TestCase):
    def test_reads_example_and_round_trips(self) -> None:
        grid = read_csv_grid(str(EXAMPLES / "measurement.csv"))
        self.assertEqual(grid[0][0], 2.1)
        self.assertIsNone(grid[4][8])
        self.assertEqual(read_csv_grid(format_csv_grid(grid), is_text=True), grid)

    def test_measurement_files_csv_and_json_agree(self) -> None:
        from_csv = read_measurement_file(str(EXAMPLES / "measurement.csv"))
        from_json = read_measurement_file(str(EXAMPLES / "measurement.json"))
        self.assertEqual(from_csv, from_json)
        self.assertEqual(set(from_json), {"deviations_um"})  # metadata stays local

    def test_errors_name_line_and_column(self) -> None:
        text = "\n".join(["1,2,3,4,5,6,7,8,9"] * 2 + ["1,2,3,4,5,6,abc,8,9"] + ["1,2,3,4,5,6,7,8,9"] * 2)
        with self.assertRaisesRegex(ValueError, r"line 3, column 7: 'abc' is not a number"):
            read_csv_grid(text, is_text=True)
        with self.assertRaisesRegex(ValueError, r"line 2: 8 cells, expected 9"):
            read_csv_grid("1,2,3,4,5,6,7,8,9\n1,2,3,4,5,6,7,8\n", is_text=True)


if __name__ == "__main__":
    unittest.main()
