"""gearloop_client: a small Python client of the gearloop HTTP API (standard library only).

The API is described in api/openapi.yaml; this module sends JSON and returns the decoded JSON
answers as plain dicts and lists, with one method per endpoint. Any API error answer
({"error": {"code", "message", "field"}}) is raised as :class:`GearloopApiError`; a server that
cannot be reached, times out, or answers 5xx raises :class:`GearloopTransportError`.

Example::

    from gearloop_client import Client, read_csv_grid

    client = Client("http://127.0.0.1:8080")
    request = {"gear": {...}, "wheel": {"radius_mm": 350}, "flank": "right",
               "measurement": {"deviations_um": read_csv_grid("part7.csv")}}
    job = client.create_correction(request)
    print(job["id"], job["result"]["status"], job["result"]["residual_rms_um"])

Grids are lists of rows (row 0 at the root side, each row from x < 0 to x > 0) of floats in
micrometres, None where a point is missing, as in the API.

Spiral-bevel pinions (docs/bevel-machines.md) have their own methods, named bevel_*: each takes
the pinion flank's "job" (side plus the cradle summary, or {"side": ..., "published": True} for
the pinion of Tang 2011 Table 1) and the free-form generator's axis polynomials ("motion":
A_rad, B_rad, X_mm, Y_mm, Z_mm, optional C_rad; coefficient k multiplies t^k, t the cradle roll
in rad). For example::

    job = {"side": "concave", "published": True}
    converted = client.bevel_conversion(job, polynomial_degree=5)
    cmm = client.simulate_bevel_measurement(job, hidden_errors={"X_mm": [0.008]}, noise_um=0.2)
    correction = client.create_bevel_correction(job, cmm["measurement"], motion=converted["motion"])
    next_motion = correction["result"]["motion"]
"""

from __future__ import annotations

import csv
import io
import json
import math
import time
import urllib.error
import urllib.parse
import urllib.request
from typing import Any, Dict, List, Optional, Sequence

__all__ = [
    "BEVEL_MACHINE_KIND",
    "Client",
    "GearloopError",
    "GearloopApiError",
    "GearloopTransportError",
    "Grid",
    "read_csv_grid",
    "read_measurement_file",
    "read_machine_file",
    "format_csv_grid",
]

Json = Dict[str, Any]
Grid = List[List[Optional[float]]]

# machine.kind of the spiral-bevel free-form generator, which the server uses to tell bevel
# requests from the grinder's on the shared endpoints (corrections, simulations).
BEVEL_MACHINE_KIND = "free-form-bevel-generator"


def _with_optional(body: Json, **fields: Any) -> Json:
    """body plus each field whose value is not None (None = leave it to the server's default)."""
    for name, value in fields.items():
        if value is not None:
            body[name] = value
    return body


class GearloopError(Exception):
    """Base class of the errors this client raises."""


class GearloopApiError(GearloopError):
    """The server answered with an API error body (a 4xx): the request was refused.

    Attributes:
        status: the HTTP status (400 wrong shape, 404 not found, 422 invalid value, ...).
        code: the API's error code ("invalid_request", "invalid_value", "not_found", ...).
        message: what was wrong, for a person.
        field: where in the request, as a path ("measurement.deviations_um[2][7]"), or "".
    """

    def __init__(self, status: int, code: str, message: str, field: str = "") -> None:
        self.status = status
        self.code = code
        self.message = message
        self.field = field
        where = f" at {field}" if field else ""
        super().__init__(f"{status} {code}{where}: {message}")


class GearloopTransportError(GearloopError):
    """No usable answer: connection refused, timeout, a 5xx, or a body that is not JSON."""

    def __init__(self, message: str, status: int = 0) -> None:
        self.status = status
        super().__init__(message)


class Client:
    """A client of one gearloop server.

    Args:
        server: base URL, e.g. "http://127.0.0.1:8080" (no path).
        token: sent as "Authorization: Bearer <token>" when given.
        timeout: seconds allowed for each request.
    """

    def __init__(self, server: str = "http://127.0.0.1:8080", token: Optional[str] = None,
                 timeout: float = 120.0) -> None:
        parsed = urllib.parse.urlparse(server)
        if parsed.scheme not in ("http", "https") or not parsed.netloc:
            raise ValueError(f"server must be an http(s) URL such as http://127.0.0.1:8080, got {server!r}")
        self.server = server.rstrip("/")
        self.token = token
        self.timeout = timeout

    # --- transport ------------------------------------------------------------------------

    def _request(self, method: str, path: str, body: Optional[Json] = None,
                 query: Optional[Dict[str, Any]] = None, expect_json: bool = True) -> Any:
        url = self.server + path
        if query:
            pairs = {k: v for k, v in query.items() if v is not None}
            if pairs:
                url += "?" + urllib.parse.urlencode(pairs)
        data = None
        headers = {"Accept": "application/json"}
        if body is not None:
            data = json.dumps(body, allow_nan=False).encode("utf-8")
            headers["Content-Type"] = "application/json"
        if self.token:
            headers["Authorization"] = "Bearer " + self.token
        request = urllib.request.Request(url, data=data, headers=headers, method=method)
        try:
            with urllib.request.urlopen(request, timeout=self.timeout) as response:
                status = response.status
                text = response.read().decode("utf-8")
        except urllib.error.HTTPError as error:
            status = error.code
            text = error.read().decode("utf-8", errors="replace")
        except (urllib.error.URLError, OSError) as error:
            reason = getattr(error, "reason", error)
            raise GearloopTransportError(f"cannot reach {self.server}: {reason}") from error
        if status >= 500:
            raise GearloopTransportError(f"server error {status} on {method} {path}: {text[:200]}", status)
        if status >= 400:
            try:
                err = json.loads(text).get("error", {})
            except (ValueError, AttributeError):
                err = {}
            if not isinstance(err, dict):
                err = {}
            raise GearloopApiError(status, str(err.get("code", "error")), str(err.get("message", text[:200])),
                                   str(err.get("field", "") or ""))
        if not expect_json:
            return text
        try:
            return json.loads(text)
        except ValueError as error:
            raise GearloopTransportError(f"{method} {path} answered {status} with a body that is not JSON",
                                         status) from error

    # --- service ----------------------------------------------------------------------------

    def health(self) -> Json:
        """GET /healthz: {"status": "ok", "version": ...}."""
        return self._request("GET", "/healthz")

    def metrics(self) -> str:
        """GET /metrics: Prometheus text."""
        return self._request("GET", "/metrics", expect_json=False)

    # --- model --------------------------------------------------------------------------------

    def nominal(self, setup: Json) -> Json:
        """POST /api/v1/nominal: gear, wheel, machine, flank -> nominal "settings" (and roll range)."""
        return self._request("POST", "/api/v1/nominal", setup)

    def evaluate(self, request: Json) -> Json:
        """POST /api/v1/evaluate: setup + settings -> "deviations_um" on the grid, "not_reached"."""
        return self._request("POST", "/api/v1/evaluate", request)

    def sensitivity(self, request: Json) -> Json:
        """POST /api/v1/sensitivity: setup + settings -> "matrix" (um per unit), "singular_values", "rank"."""
        return self._request("POST", "/api/v1/sensitivity", request)

    # --- corrections ----------------------------------------------------------------------------

    def create_correction(self, request: Json) -> Json:
        """POST /api/v1/corrections: a correction request -> the stored job {"id", "status", "result"}.

        A valid request whose solve does not converge is still a job (check result["status"]).
        result["exact_search"] says what the exact-model search did ("outcome": "not run: ...",
        "taken: ...", "kept the regularised answer: ...", "refused by the safe step (...): ...", ""
        for lsq-plain and pso) with its two
        exact predictions in um ("regularised_predicted_rms_um", "searched_predicted_rms_um"; None
        when not computed); a job stored before the field existed has no "exact_search".
        """
        return self._request("POST", "/api/v1/corrections", request)

    def list_corrections(self, limit: Optional[int] = None, offset: Optional[int] = None,
                         **filters: Any) -> Json:
        """GET /api/v1/corrections: {"jobs": [...newest first], "total", "limit", "offset"}.

        Filters (query parameters): kind, status, flank, teeth, module_mm, created_from, created_to,
        and the trace of a job: part_number, serial, tooth, machine_id, file_name, batch_id,
        submitted_by.
        """
        query: Dict[str, Any] = {"limit": limit, "offset": offset}
        query.update(filters)
        return self._request("GET", "/api/v1/corrections", query=query)

    def get_correction(self, job_id: int) -> Json:
        """GET /api/v1/corrections/{id}: the job with its "request" and "result"."""
        return self._request("GET", f"/api/v1/corrections/{int(job_id)}")

    def correction_settings(self, job_id: int, format: str = "csv", samples: Optional[int] = None) -> str:
        """GET /api/v1/corrections/{id}/settings: the corrected settings as text for the machine
        (docs/settings-listing.md): format "csv", "table" or "nc"; samples = roll angles the axis
        motion is listed at (server default 9)."""
        query: Dict[str, Any] = {"format": format, "samples": samples}
        return self._request("GET", f"/api/v1/corrections/{int(job_id)}/settings", query=query,
                             expect_json=False)

    def openapi_document(self) -> str:
        """GET /api/v1/openapi.yaml: the API contract the server was built with (YAML text)."""
        return self._request("GET", "/api/v1/openapi.yaml", expect_json=False)

    def lineage(self, job_id: int) -> Json:
        """GET /api/v1/corrections/{id}/lineage: {"jobs": [...]} the chain of settings revisions."""
        return self._request("GET", f"/api/v1/corrections/{int(job_id)}/lineage")

    def replay(self, job_id: int, options: Optional[Json] = None, target: Optional[Json] = None) -> Json:
        """POST /api/v1/corrections/{id}/replay: the stored measurement again with changed options
        (merged over the stored ones; None removes a field) and/or a new target -> a new job."""
        body: Json = {}
        if options is not None:
            body["options"] = options
        if target is not None:
            body["target"] = target
        return self._request("POST", f"/api/v1/corrections/{int(job_id)}/replay", body)

    # --- batches --------------------------------------------------------------------------------

    def create_batch(self, items: Sequence[Json]) -> Json:
        """POST /api/v1/batches: many correction requests, run in the background -> {"id", ...}."""
        return self._request("POST", "/api/v1/batches", {"items": list(items)})

    def get_batch(self, batch_id: int) -> Json:
        """GET /api/v1/batches/{id}: "status" ("running"/"finished"), "done", "failed", "items"."""
        return self._request("GET", f"/api/v1/batches/{int(batch_id)}")

    def wait_batch(self, batch_id: int, timeout: float = 300.0, poll: float = 0.2) -> Json:
        """Polls get_batch until the batch is no longer running; raises TimeoutError after `timeout` s."""
        deadline = time.monotonic() + timeout
        while True:
            batch = self.get_batch(batch_id)
            if batch.get("status") != "running":
                return batch
            if time.monotonic() > deadline:
                raise TimeoutError(f"batch {batch_id} still running after {timeout} s")
            time.sleep(poll)

    # --- simulations -------------------------------------------------------------------------------

    def simulate_measurement(self, scenario: Json) -> Json:
        """POST /api/v1/simulations/measurement: a simulated CMM grid ("measurement")."""
        return self._request("POST", "/api/v1/simulations/measurement", scenario)

    def simulate_closed_loop(self, scenario: Json) -> Json:
        """POST /api/v1/simulations/closed-loop: {"iterations": [{part, true_rms_um, ...}], ...}.

        Takes a grinder scenario, or a bevel one (machine.kind "free-form-bevel-generator"; see
        simulate_bevel_closed_loop)."""
        return self._request("POST", "/api/v1/simulations/closed-loop", scenario)

    # --- spiral-bevel pinions (free-form generator) ------------------------------------------------

    def bevel_conversion(self, job: Json, polynomial_degree: Optional[int] = None,
                         max_flank_distance_um: Optional[float] = None, **options: Any) -> Json:
        """POST /api/v1/bevel/conversions: the cradle summary of `job` as free-form axis polynomials.

        Args:
            job: the pinion flank, {"side": "convex"|"concave", "cutter", "machine", "blank",
                "grid"} or {"side": ..., "published": True}; lengths in mm, angles in degrees.
            polynomial_degree: the degree of every axis polynomial (1 to 12; server default 5).
            max_flank_distance_um: instead of a degree, the flank tolerance in um: the smallest
                degree in [2, 12] whose motions cut the flank within it of the cradle flank.
            **options: further conversion options (num_samples, num_check_samples,
                roll_margin_fraction).

        Returns:
            {"degree", "motion" (A_rad, B_rad, X_mm, Y_mm, Z_mm, C_rad; coefficient k multiplies
            t^k, t the cradle roll in rad), "roll_range_deg", "fit_residual" (per axis, max_rad/
            rms_rad or max_mm/rms_mm), "exact", "fitted", "flank_distance" ({"max_um", "rms_um",
            ...}), "rows", "columns", "points"}.
        """
        body: Json = {"job": job}
        opts = _with_optional(dict(options), polynomial_degree=polynomial_degree,
                              max_flank_distance_um=max_flank_distance_um)
        if opts:
            body["options"] = opts
        return self._request("POST", "/api/v1/bevel/conversions", body)

    def bevel_evaluate(self, job: Json, motion: Optional[Json] = None) -> Json:
        """POST /api/v1/bevel/evaluate: the flank that `motion` cuts, against the cradle flank.

        Args:
            job: the pinion flank (as in bevel_conversion).
            motion: free-form axis polynomials {A_rad, B_rad, X_mm, Y_mm, Z_mm[, C_rad]}, all of
                one length (degree + 1); None = the motions converted from the summary (degree 5).

        Returns:
            {"deviations_um" (rows x columns grid in um, positive = material left on, None where
            the cutter does not reach), "not_reached", "reached", "rows", "columns", "points"
            (cone distance mm, polar angle deg, roll deg, position mm, normal), "motion", "job"}.
        """
        return self._request("POST", "/api/v1/bevel/evaluate", _with_optional({"job": job}, motion=motion))

    def bevel_axis_sensitivity(self, job: Json, motion: Optional[Json] = None,
                               linear_error_mm: Optional[float] = None,
                               angular_error_deg: Optional[float] = None,
                               exact: Optional[bool] = None) -> Json:
        """POST /api/v1/bevel/axis-sensitivity: the flank error each axis error causes, ranked.

        Args:
            job: the pinion flank (as in bevel_conversion).
            motion: the axis polynomials to perturb; None = the converted ones.
            linear_error_mm: the offset of X, Y, Z in mm (server default 0.01).
            angular_error_deg: the offset of A, B in degrees (server default 0.01).
            exact: also re-evaluate the exact model with each offset (server default True).

        Returns:
            {"offsets", "coefficients" (one row per parameter: max_abs_um, rms_um, grid_um, ...),
            "offset_ranking", "coefficient_ranking" (largest rms flank error first), ...}.
        """
        errors = _with_optional({}, linear_error_mm=linear_error_mm, angular_error_deg=angular_error_deg,
                                exact=exact)
        body = _with_optional({"job": job}, motion=motion)
        if errors:
            body["errors"] = errors
        return self._request("POST", "/api/v1/bevel/axis-sensitivity", body)

    def create_bevel_correction(self, job: Json, measurement: Json, motion: Optional[Json] = None,
                                target: Optional[Json] = None, options: Optional[Json] = None,
                                settings_source_job_id: Optional[int] = None) -> Json:
        """POST /api/v1/corrections with machine.kind "free-form-bevel-generator": a correction of
        the free-form axis polynomials from a measured pinion flank, stored as a job.

        Args:
            job: the pinion flank (as in bevel_conversion); its grid gives the measurement's shape.
            measurement: {"deviations_um": grid in um} or {"teeth": [grids]}, None where a point
                was not delivered.
            motion: the axis polynomials the measured pinion was cut with; None = the converted ones.
            target: {"deviations_um": grid in um} to aim at (default all 0).
            options: correction options as the grinder's (blocks A, B, X, Y, Z), e.g.
                {"default_max_order": 2, "probe_noise_um": 0.2}.
            settings_source_job_id: the stored job whose motion the pinion was cut with (lineage).

        Returns:
            The stored job {"id", "kind", "status", "result"}; result holds "motion" (the corrected
            polynomials), "delta", "commanded_motion", "predicted_residual_um", "residual_rms_um"
            (um), "axis_motion" (A, B in urad, X, Y, Z in um), "status", ...
        """
        body = _with_optional({"machine": {"kind": BEVEL_MACHINE_KIND}, "job": job, "measurement": measurement},
                              motion=motion, target=target, options=options,
                              settings_source_job_id=settings_source_job_id)
        return self._request("POST", "/api/v1/corrections", body)

    def simulate_bevel_measurement(self, job: Json, motion: Optional[Json] = None,
                                   hidden_errors: Optional[Json] = None, noise_um: Optional[float] = None,
                                   seed: Optional[int] = None, **extra: Any) -> Json:
        """POST /api/v1/simulations/measurement for a pinion cut by the free-form generator.

        Args:
            job: the pinion flank (as in bevel_conversion).
            motion: the commanded axis polynomials; None = the converted ones.
            hidden_errors: coefficient errors of the machine's axes, added to what it is commanded:
                {"A_rad": [...], "B_rad": [...], "X_mm": [...], "Y_mm": [...], "Z_mm": [...]} (a
                shorter array is padded with 0).
            noise_um: the probe noise's standard deviation in um (server default 0).
            seed: the noise's seed (server default 1).
            **extra: teeth, outlier_probability, outlier_size_um (um), missing_probability.

        Returns:
            {"measurement": {"deviations_um", ...}, "true_deviations_um", "outliers", "missing",
            "not_reached", "hidden_errors", "motion", "machine_kind"}; grids in um.
        """
        body = _with_optional({"machine": {"kind": BEVEL_MACHINE_KIND}, "job": job}, motion=motion,
                              hidden_errors=hidden_errors, noise_um=noise_um, seed=seed)
        body.update(extra)
        return self._request("POST", "/api/v1/simulations/measurement", body)

    def simulate_bevel_closed_loop(self, job: Json, motion: Optional[Json] = None,
                                   hidden_errors: Optional[Json] = None, noise_um: Optional[float] = None,
                                   seed: Optional[int] = None, corrections: Optional[int] = None,
                                   target: Optional[Json] = None, options: Optional[Json] = None,
                                   store: Optional[bool] = None, **extra: Any) -> Json:
        """POST /api/v1/simulations/closed-loop for the free-form generator: cut with the commanded
        motion plus the hidden errors, measure, correct, cut again.

        Args:
            job, motion, hidden_errors, noise_um, seed, **extra: the scenario, as in
                simulate_bevel_measurement.
            corrections: how many corrections (1 to 20; server default 3): corrections + 1 parts.
            target: {"deviations_um": grid in um} to aim at (default all 0).
            options: correction options (as in create_bevel_correction); probe_noise_um defaults
                to noise_um.
            store: store each usable correction as a replayable job (kind "closed_loop"); needs a
                write token when the server has tokens.

        Returns:
            {"machine_kind", "completed", "message", "hidden_errors", "iterations": [{"part",
            "motion" (the commanded polynomials), "true_rms_um", "true_max_um", "measured_rms_um",
            "true_error_um", "correction" (the solve's summary, None for the last part), "job_id"
            (with store)}]}.
        """
        body = _with_optional({"machine": {"kind": BEVEL_MACHINE_KIND}, "job": job}, motion=motion,
                              hidden_errors=hidden_errors, noise_um=noise_um, seed=seed,
                              corrections=corrections, target=target, options=options, store=store)
        body.update(extra)
        return self._request("POST", "/api/v1/simulations/closed-loop", body)

    # --- measuring-machine files (shared/design/METROLOGY.md) ------------------------------------

    def import_measurement(self, gear: Json, file: Json, flank: Optional[str] = None,
                           grid: Optional[Json] = None, tooth: Optional[int] = None,
                           datum_face: Optional[str] = None,
                           sign_factors: Optional[Json] = None) -> Json:
        """POST /api/v1/measurements/import: a gear measuring machine's file onto the grid.

        Args:
            gear: the gear the file is about (authoritative; the file's header must agree).
            file: {"format": "mka" | "gde", "content": text}, e.g. read_machine_file(path).
            flank, grid: as in a correction request (default right, 5 x 9).
            tooth: one tooth (default: the mean of all teeth of the flank).
            datum_face: "x_negative" | "x_positive" (default: the file's own, else x_negative).
            sign_factors: {"profile_right", "profile_left", "helix_right", "helix_left"}: +1 / -1.

        Returns:
            {"deviations_um", "figures" (ISO 1328-1, um), "classes" (1..11, None = worse than 11),
            "warnings", "not_measured", "teeth", "max_crossing_mismatch_um", ...}. A file the
            server refuses raises GearloopApiError 422 (code "invalid_file", the message naming
            the file line or element path), or 413 for one over 4 MiB.
        """
        body = _with_optional({"gear": gear, "format": file["format"], "content": file["content"]},
                              flank=flank, grid=grid, tooth=tooth, datum_face=datum_face,
                              sign_factors=sign_factors)
        if "tooth" not in body and file.get("tooth") is not None:
            body["tooth"] = file["tooth"]
        return self._request("POST", "/api/v1/measurements/import", body)

    def create_correction_from_file(self, request: Json, file: Json) -> Json:
        """POST /api/v1/corrections with "measurement": {"file": file}: the server reads the
        measuring machine's file ({"format", "content", optional "tooth", "datum_face",
        "sign_factors"}) onto the request's grid; the stored job keeps it, so a replay reads it
        again. The result carries "iso1328": the ISO 1328-1 figures and classes of the measured,
        target-relative and predicted flank."""
        body = dict(request)
        body["measurement"] = {"file": dict(file)}
        return self._request("POST", "/api/v1/corrections", body)

    def export_correction(self, job_id: int, format: str = "gde") -> str:
        """GET /api/v1/corrections/{id}/export?format=gde: the stored job as GDE XML text (gear
        data, the measured, target and predicted nets, the ISO 1328-1 figures)."""
        return self._request("GET", f"/api/v1/corrections/{int(job_id)}/export", query={"format": format},
                             expect_json=False)

    # --- plunge-shaving cutter target (SHAVING.md) ------------------------------------------------

    def shaving_cutter_target(self, work_gear: Json, cutter: Json,
                              diagonal_modification: Optional[Json] = None,
                              centre_distance_mm: Optional[float] = None, grid: Optional[Json] = None,
                              wheel_check: Optional[Json] = None) -> Json:
        """POST /api/v1/shaving/cutter-target: the cutter flank that shaves a modified work gear.

        Args:
            work_gear: the work gear ("pinion"), a gear object (degrees, unsigned helix with
                "hand"); tip_radius_mm / root_radius_mm may be left out (r_j + m_n, r_j - 1.25 m_n).
            cutter: the plunge-shaving cutter, a gear object (its root radius is the radius the
                grinding wheel's rim reaches).
            diagonal_modification: {"root_um", "tip_um", "root_band", "tip_band", "exponent",
                "root_slope", "tip_slope"}; None = no modification.
            centre_distance_mm: None = the standard installation r_j1 + r_js.
            grid: the cutter's grid (None = 5 x 9 default).
            wheel_check: {"h_s_mm", "traverse_mm_per_rad"} for the minimum wheel radii.

        Returns:
            {"crossed_axes_angle_deg", "centre_distance_mm", "delta_s_um", "base_um",
            "stock_target_um" (the correction target; None where the work gear does not generate
            the point), "outside_work_flank", "not_converged" ([row, column] lists), "contacts",
            "contact_line_length_mm", "wheel_radius_min_mm" ({"fixed", "traversing"}),
            "elapsed_ms", ...}. The same body is accepted by create_correction as
            request["target"] = {"shaving": body}.
        """
        body = _with_optional({"work_gear": work_gear, "cutter": cutter},
                              diagonal_modification=diagonal_modification,
                              centre_distance_mm=centre_distance_mm, grid=grid,
                              wheel_check=wheel_check)
        return self._request("POST", "/api/v1/shaving/cutter-target", body)
    # --- split bevel wheels on a head-head 5-axis machine (docs/split-bevel.md) ---------------

    def split_trajectory(self, gear: Json, tool: Json, cut: Optional[Json] = None,
                         machine: Optional[Json] = None, setup: Optional[Json] = None,
                         nc: Optional[bool] = None) -> Json:
        """POST /api/v1/bevel/split-trajectory: the 5-axis flank-milling trajectory of one slot of a
        split equal-base-circle bevel wheel, stored as a job (needs a write token when the server
        has tokens).

        Args:
            gear: {"teeth", "pitch_angle_deg", "outer_cone_distance_mm" or
                "outer_transverse_module_mm", "face_width_mm", "mean_spiral_angle_deg" or
                "outer_spiral_angle_deg", "hand", "pressure_angle_deg", optional "addendum_mm",
                "dedendum_mm", "slot_width_mm"} (mm, degrees).
            tool: {"radius_mm", optional "stock_mm"}: the end mill.
            cut: {"slot_index", "flanks", "depth_levels", "steps" or "chord_tolerance_mm", "from",
                "feed_mm_per_min"} (server defaults when absent).
            machine: {"pivot_length_mm", "a_limits_deg", "b_limits_deg"}.
            setup: {"apex_mm", "segment_mid_deg", "segment_angle_deg"}.
            nc: True to have the answer carry "nc_program" (the stored job always keeps it).

        Returns:
            {"derived", "setup", "passes": [{"slot", "flank", "level", "tip_height_mm",
            "side_deviation_mm": {"min", "max"}, "points": [{"arc_mm", ..., "X_mm", "Y_mm", "Z_mm",
            "A_deg", "B_deg"}]}], "job_id", "location", "nc_location", "nc_program" (with nc)}.

        Raises:
            GearloopApiError: 422 naming the field for every refusal of SPLIT_BEVEL.md section 8.
        """
        body = _with_optional({"gear": gear, "tool": tool}, cut=cut, machine=machine, setup=setup)
        if nc is not None:
            body["output"] = {"nc": nc}
        return self._request("POST", "/api/v1/bevel/split-trajectory", body)

    def split_trajectory_nc(self, job_id: int) -> str:
        """GET /api/v1/bevel/split-trajectory/{id}/nc: the stored job's NC program as text."""
        return self._request("GET", f"/api/v1/bevel/split-trajectory/{int(job_id)}/nc", expect_json=False)


# --- CSV grids (clients/FORMATS.md; the same format as the gearloop CLI) -------------------------


def read_machine_file(path: str, format: Optional[str] = None) -> Json:
    """A gear measuring machine's file as the API takes it: {"format", "content"}.

    The format is "mka" for a .mka name and "gde" for .xml or .gde unless given. The bytes are
    read as UTF-8 (a byte-order mark is kept; the server drops it) or, when they are not UTF-8,
    as Latin-1 (older P-series exports)."""
    if format is None:
        lower = path.lower()
        if lower.endswith(".mka"):
            format = "mka"
        elif lower.endswith(".xml") or lower.endswith(".gde"):
            format = "gde"
        else:
            raise ValueError(f"cannot tell the format of {path} from its name: give format='mka' or 'gde'")
    if format not in ("mka", "gde"):
        raise ValueError(f"format must be 'mka' or 'gde', got {format!r}")
    with open(path, "rb") as f:
        data = f.read()
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        text = data.decode("latin-1")
    return {"format": format, "content": text}

def read_csv_grid(path_or_text: str, rows: int = 5, columns: int = 9, allow_missing: bool = True,
                  is_text: bool = False) -> Grid:
    """Reads a CSV grid (first data line = row 0, root side; optional header line; empty cell or
    "null" = missing). Raises ValueError naming the line and column of the first problem."""
    if is_text:
        text = path_or_text
    else:
        with open(path_or_text, encoding="utf-8-sig", newline="") as f:
            text = f.read()
    grid: Grid = []
    first = True
    for line_number, cells in enumerate(csv.reader(io.StringIO(text)), start=1):
        if not cells or all(not c.strip() for c in cells) or cells[0].lstrip().startswith("#"):
            continue
        cells = [c.strip() for c in cells]
        if len(cells) == columns + 1 and cells[-1] == "":
            cells.pop()
        if first:
            first = False
            if all(not _is_number(c) for c in cells) and any(c and c.lower() != "null" for c in cells):
                continue  # header
        if len(grid) >= rows:
            raise ValueError(f"line {line_number}: more than {rows} data rows")
        if len(cells) != columns:
            raise ValueError(f"line {line_number}: {len(cells)} cells, expected {columns}")
        row: List[Optional[float]] = []
        for column, cell in enumerate(cells, start=1):
            if cell == "" or cell.lower() == "null":
                if not allow_missing:
                    raise ValueError(f"line {line_number}, column {column}: missing value")
                row.append(None)
                continue
            if not _is_number(cell):
                raise ValueError(f"line {line_number}, column {column}: {cell!r} is not a number")
            value = float(cell)
            if not math.isfinite(value):
                raise ValueError(f"line {line_number}, column {column}: {cell!r} is not a finite number")
            row.append(value)
        grid.append(row)
    if len(grid) != rows:
        raise ValueError(f"end of file after {len(grid)} data rows, expected {rows}")
    return grid


def read_measurement_file(path: str, rows: int = 5, columns: int = 9) -> Json:
    """Reads a measurement file into the API's measurement object, as the gearloop CLI does:
    a CSV grid, or JSON with "deviations_um" (or "teeth"), possibly inside "measurement", or a
    bare array of rows (clients/FORMATS.md). Raises ValueError naming what is wrong."""
    if path.lower().endswith(".csv"):
        try:
            return {"deviations_um": read_csv_grid(path, rows, columns)}
        except ValueError as error:
            raise ValueError(f"{path}: {error}") from None
    with open(path, encoding="utf-8") as f:
        try:
            data = json.load(f)
        except ValueError as error:
            raise ValueError(f"{path}: not valid JSON: {error}") from None
    if isinstance(data, dict) and "measurement" in data:
        data = data["measurement"]
    if isinstance(data, list):
        data = {"deviations_um": data}
    if not isinstance(data, dict) or ("deviations_um" not in data and "teeth" not in data):
        raise ValueError(f'{path}: a measurement file holds "deviations_um" or "teeth"')
    out: Json = {}
    if "deviations_um" in data:
        grid = data["deviations_um"]
        if (not isinstance(grid, list) or len(grid) != rows
                or any(not isinstance(row, list) or len(row) != columns for row in grid)
                or any(v is not None and not isinstance(v, (int, float)) for row in grid for v in row)):
            raise ValueError(f"{path}: deviations_um must be {rows} rows of {columns} numbers or null")
        out["deviations_um"] = grid
    if "teeth" in data:
        out["teeth"] = data["teeth"]
    return out


def format_csv_grid(grid: Grid, header: bool = True) -> str:
    """Writes a grid as CSV (row 0 first, missing = empty cell), with an "L1,...,Ln" header line."""
    out = io.StringIO()
    if header and grid:
        out.write(",".join(f"L{c + 1}" for c in range(len(grid[0]))) + "\n")
    for row in grid:
        out.write(",".join("" if v is None else repr(float(v)) for v in row) + "\n")
    return out.getvalue()


def _is_number(text: str) -> bool:
    """True when float() reads the whole cell ("nan" and "inf" too: those are refused as not finite)."""
    try:
        float(text)
    except ValueError:
        return False
    return True
