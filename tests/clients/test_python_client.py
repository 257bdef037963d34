"""Tests of clients/python/gearloop_client.py against a real gearloop-server (server_fixture)."""

from __future__ import annotations

import copy
import unittest

from gearloop_client import (Client, GearloopApiError, GearloopTransportError, format_csv_grid,
                             read_csv_grid, read_measurement_file)
from server_fixture import EXAMPLES, RunningServer, example_json, free_port, write_token_file


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

        stored = self.client.get_correction(job["id"])
        self.assertEqual(stored["id"], job["id"])
        self.assertEqual(stored["request"]["measurement"], self.request["measurement"])
        listed = self.client.list_corrections(limit=5)
        self.assertIn(job["id"], [j["id"] for j in listed["jobs"]])
        self.assertEqual(listed["jobs"][0]["id"], max(j["id"] for j in listed["jobs"]))  # newest first
        only = self.client.list_corrections(limit=50, kind="replay")
        self.assertTrue(all(j["kind"] == "replay" for j in only["jobs"]))

        replay = self.client.replay(job["id"], options={"solver": "lsq-plain"})
        self.assertEqual(replay["parent_job_id"], job["id"])
        self.assertEqual(replay["kind"], "replay")
        self.assertEqual(replay["result"]["solver"], "lsq-plain")
        lineage = self.client.lineage(replay["id"])
        self.assertIn(replay["id"], [j["id"] for j in lineage["jobs"]])

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
        simulated = self.client.simulate_measurement(scenario)
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
