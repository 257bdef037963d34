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
    "Client",
    "GearloopError",
    "GearloopApiError",
    "GearloopTransportError",
    "Grid",
    "read_csv_grid",
    "read_measurement_file",
    "format_csv_grid",
]

Json = Dict[str, Any]
Grid = List[List[Optional[float]]]


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
        """
        return self._request("POST", "/api/v1/corrections", request)

    def list_corrections(self, limit: Optional[int] = None, offset: Optional[int] = None,
                         **filters: Any) -> Json:
        """GET /api/v1/corrections: {"jobs": [...newest first], "total", "limit", "offset"}.

        Filters (query parameters): kind, status, flank, teeth, module_mm, created_from, created_to.
        """
        query: Dict[str, Any] = {"limit": limit, "offset": offset}
        query.update(filters)
        return self._request("GET", "/api/v1/corrections", query=query)

    def get_correction(self, job_id: int) -> Json:
        """GET /api/v1/corrections/{id}: the job with its "request" and "result"."""
        return self._request("GET", f"/api/v1/corrections/{int(job_id)}")

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
        """POST /api/v1/simulations/closed-loop: {"iterations": [{part, true_rms_um, ...}], ...}."""
        return self._request("POST", "/api/v1/simulations/closed-loop", scenario)


# --- CSV grids (clients/FORMATS.md; the same format as the gearloop CLI) -------------------------


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
