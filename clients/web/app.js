// clients/web/app.js: the dashboard. Lists the job history (GET /api/v1/corrections), shows the
// selected job (#job=ID in the address, so a view can be bookmarked) with its topographies, axis
// corrections and the convergence of its lineage, and can run a simulated closed loop on the
// job's setup. Everything goes through the same HTTP API as the other clients.
"use strict";

(function () {
  const P = GearloopPlots;
  const S = GearloopShopFloor;
  const PAGE = 25;
  const state = { offset: 0, total: 0, selected: null };
  const $ = (id) => document.getElementById(id);

  function token() {
    try {
      return localStorage.getItem("gearloop.token") || "";
    } catch (e) {
      return "";
    }
  }

  // fetch + JSON + the API's error body turned into an Error with code and field.
  async function api(method, path, body) {
    const headers = { Accept: "application/json" };
    if (token()) headers.Authorization = "Bearer " + token();
    if (body !== undefined) headers["Content-Type"] = "application/json";
    const res = await fetch(path, { method, headers, body: body === undefined ? undefined : JSON.stringify(body) });
    const data = await res.json().catch(() => null);
    if (!res.ok) {
      const e = (data && data.error) || {};
      const err = new Error(res.status + " " + (e.code || "error") + (e.field ? " at " + e.field : "") + ": " + (e.message || res.statusText));
      err.status = res.status;
      throw err;
    }
    return data;
  }

  // GET of a text answer (a CSV listing); the API's JSON error body turned into an Error.
  async function apiText(path) {
    const headers = token() ? { Authorization: "Bearer " + token() } : {};
    const res = await fetch(path, { headers });
    const text = await res.text();
    if (!res.ok) {
      let e = {};
      try {
        e = JSON.parse(text).error || {};
      } catch (ignored) {
        e = { message: text };
      }
      throw new Error(res.status + " " + (e.code || "error") + (e.field ? " at " + e.field : "") + ": " + (e.message || res.statusText));
    }
    return text;
  }

  function message(text, cls) {
    return P.html("p", { class: cls || "error", text });
  }

  async function loadHealth() {
    try {
      const h = await api("GET", "/healthz");
      $("health").textContent = "server " + h.status + " \u00b7 " + h.version;
      $("health").className = "health ok";
    } catch (e) {
      $("health").textContent = "server unreachable";
      $("health").className = "health bad";
    }
  }

  async function loadJobs() {
    const params = new URLSearchParams({ limit: PAGE, offset: state.offset });
    if ($("filter-kind").value) params.set("kind", $("filter-kind").value);
    if ($("filter-status").value) params.set("status", $("filter-status").value);
    const body = $("jobs").querySelector("tbody");
    try {
      const page = await api("GET", "/api/v1/corrections?" + params.toString());
      state.total = page.total;
      body.textContent = "";
      for (const job of page.jobs) {
        const tr = P.html("tr", { "data-job-id": job.id, class: job.id === state.selected ? "selected" : "" }, [
          P.html("td", { text: String(job.id) }),
          P.html("td", { text: job.kind }),
          P.html("td", { class: "status-" + job.status, text: job.status }),
          P.html("td", { class: "num", text: P.fmt(job.residual_rms_um, 3) }),
          P.html("td", { title: job.created_utc || "", text: (job.created_utc || "").slice(5, 19).replace("T", " ") }),
        ]);
        tr.addEventListener("click", () => {
          window.location.hash = "job=" + job.id;
        });
        body.appendChild(tr);
      }
      if (!page.jobs.length) body.appendChild(P.html("tr", {}, [P.html("td", { colspan: 5, text: "no jobs yet" })]));
      const last = Math.min(state.offset + page.jobs.length, state.total);
      $("page-info").textContent = (page.jobs.length ? state.offset + 1 : 0) + "\u2013" + last + " of " + state.total;
      $("newer").disabled = state.offset === 0;
      $("older").disabled = last >= state.total;
      state.newest = page.jobs.length ? page.jobs[0].id : null;
    } catch (e) {
      body.textContent = "";
      body.appendChild(P.html("tr", {}, [P.html("td", { colspan: 5, class: "error", text: e.message })]));
    }
  }

  // Full records of the job's lineage (oldest first), at most the last 20.
  async function lineage(id) {
    try {
      const chain = (await api("GET", "/api/v1/corrections/" + id + "/lineage")).jobs || [];
      return await Promise.all(chain.slice(-20).map((j) => api("GET", "/api/v1/corrections/" + j.id)));
    } catch (e) {
      return [];
    }
  }

  async function showJob(id) {
    state.selected = id;
    // Only the latest request draws: a slower earlier one must not overwrite it.
    const ticket = (state.ticket = (state.ticket || 0) + 1);
    document.body.removeAttribute("data-job-shown");
    document.body.removeAttribute("data-motion-shown");
    for (const tr of $("jobs").querySelectorAll("tbody tr")) {
      tr.classList.toggle("selected", Number(tr.getAttribute("data-job-id")) === id);
    }
    const detail = $("detail");
    detail.textContent = "";
    detail.appendChild(message("Loading job " + id + "\u2026", "loading"));
    try {
      const job = await api("GET", "/api/v1/corrections/" + id);
      if (P.isSplitTrajectory(job)) {
        if (ticket !== state.ticket) return;
        detail.textContent = "";
        showSplitTrajectory(job, detail);
        document.body.setAttribute("data-job-shown", String(id));
        return;
      }
      const chain = await lineage(id);
      if (ticket !== state.ticket) return;
      detail.textContent = "";
      const actions = P.html("div", { class: "actions" }, [
        P.html("a", { href: "/jobs/" + id + "/report", target: "_blank", class: "button", text: "Printable report" }),
      ]);
      const simulate = P.html("button", { type: "button", class: "button", text: "Simulate a closed loop on this setup" });
      // The simulated closed loop runs the grinder's scenario; a bevel job has none yet.
      if (!P.isBevel(job)) actions.appendChild(simulate);
      actions.appendChild(replayControl(job));
      detail.appendChild(actions);
      detail.appendChild(nextPartPanel(job));
      detail.appendChild(newCorrectionPanel(job));
      if (!P.isBevel(job)) detail.appendChild(targetEditor(job));
      detail.appendChild(P.renderJob(job, chain.length ? chain : [job]));
      detail.appendChild(flank3dSection(job));
      detail.appendChild(motionSection(job, ticket));
      detail.appendChild(downloads(job));
      const sim = P.html("section", { class: "simulation" });
      detail.appendChild(sim);
      simulate.addEventListener("click", () => runClosedLoop(job, sim, simulate));
      document.body.setAttribute("data-job-shown", String(id));
    } catch (e) {
      if (ticket !== state.ticket) return;
      detail.textContent = "";
      detail.appendChild(message("Cannot load job " + id + ": " + e.message));
    }
  }

  // A split-bevel trajectory job: its NC program and JSON to download, the paths, the head
  // angles along the face and the passes (no replay, next part or simulation: nothing was
  // measured).
  function showSplitTrajectory(job, detail) {
    const r = job.result || {};
    const actions = P.html("div", { class: "actions downloads" }, [P.html("span", { class: "note", text: "Download:" })]);
    if (typeof r.nc_program === "string") actions.appendChild(downloadLink("job" + job.id + ".nc", r.nc_program, "text/plain"));
    actions.appendChild(downloadLink("job" + job.id + ".json", JSON.stringify(job), "application/json"));
    detail.appendChild(actions);
    detail.appendChild(P.renderJob(job, [job]));
  }

  // Replays the stored measurement with another solver (POST .../replay); the new job opens.
  function replayControl(job) {
    const solver = P.html("select", { id: "replay-solver", "aria-label": "solver" }, ["regularised", "pso", "lsq-plain"].map((v) => P.html("option", { value: v, text: v })));
    const current = (job.result || {}).solver;
    if (current) solver.value = current;
    const button = P.html("button", { type: "button", class: "button", id: "replay", text: "Replay with solver" });
    const status = P.html("span", { class: "note", id: "replay-status" });
    button.addEventListener("click", async () => {
      button.disabled = true;
      status.className = "note";
      status.textContent = "solving\u2026";
      try {
        const created = await api("POST", "/api/v1/corrections/" + job.id + "/replay", { options: { solver: solver.value } });
        state.offset = 0;
        await loadJobs();
        window.location.hash = "job=" + created.id;
      } catch (e) {
        status.className = "error";
        status.textContent = e.message;
        button.disabled = false;
      }
    });
    return P.html("span", { class: "replay" }, [button, solver, status]);
  }

  // Reads a CSV grid by the rules of clients/FORMATS.md (the same as the CLI's csv_grid.h):
  // '#' comments and blank lines skipped, an optional header line without numbers, empty or
  // "null" = missing; errors name the line and column.
  function parseCsvGrid(text, rows, columns) {
    const grid = [];
    let first = true;
    const lines = text.replace(/^\uFEFF/, "").split(/\r?\n/);
    const isNumber = (t) => t !== "" && !Number.isNaN(Number(t)) && /^[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?$/.test(t);
    for (let i = 0; i < lines.length; ++i) {
      const line = lines[i].trim();
      if (!line || line[0] === "#") continue;
      let cells = lines[i].split(",").map((c) => c.trim().replace(/^"(.*)"$/, "$1").trim());
      if (cells.length === columns + 1 && cells[columns] === "") cells = cells.slice(0, columns);
      if (first) {
        first = false;
        if (cells.every((c) => !isNumber(c)) && cells.some((c) => c && c.toLowerCase() !== "null")) continue;
      }
      const where = "line " + (i + 1);
      if (grid.length >= rows) throw new Error(where + ": more than " + rows + " data rows");
      if (cells.length !== columns) throw new Error(where + ": " + cells.length + " cells, expected " + columns);
      grid.push(
        cells.map((c, k) => {
          if (c === "" || c.toLowerCase() === "null") return null;
          if (!isNumber(c)) throw new Error(where + ", column " + (k + 1) + ": '" + c + "' is not a number");
          return Number(c);
        })
      );
    }
    if (grid.length !== rows) throw new Error("end of file after " + grid.length + " data rows, expected " + rows);
    return grid;
  }

  // A gear measuring machine's file (Klingelnberg .mka, GDE .xml/.gde) as the API takes it:
  // {"format", "content"}; null for any other name. UTF-8, else Latin-1 (older P-series exports).
  async function machineFile(file) {
    const format = /\.mka$/i.test(file.name) ? "mka" : /\.(xml|gde)$/i.test(file.name) ? "gde" : null;
    if (!format) return null;
    const bytes = await file.arrayBuffer();
    let content;
    try {
      content = new TextDecoder("utf-8", { fatal: true }).decode(bytes);
    } catch (e) {
      content = new TextDecoder("iso-8859-1").decode(bytes);
    }
    return { format, content };
  }

  // A measured part's file as the request's "measurement", on the grid of the job: a CSV grid
  // (rows x columns of the job's grid), a JSON measurement file ({"deviations_um"} or {"teeth"}),
  // or, for a ground gear, a measuring machine's .mka / GDE file the server reads itself.
  async function readMeasurement(file, job) {
    const req = job.request || {};
    const bevel = P.isBevel(job);
    const grid = (bevel ? (req.job || {}).grid : req.grid) || {};
    const rows = grid.profile_points || 5;
    const columns = (bevel ? grid.lengthwise_points : grid.lead_points) || 9;
    const fromMachine = bevel ? null : await machineFile(file);
    // The server reads it onto this job's grid (POST /api/v1/corrections, measurement.file).
    if (fromMachine) return { file: fromMachine };
    const text = await file.text();
    if (/\.json$/i.test(file.name)) {
      let data = JSON.parse(text);
      if (data && data.measurement) data = data.measurement;
      if (Array.isArray(data)) data = { deviations_um: data };
      if (!data || (!data.deviations_um && !data.teeth)) throw new Error('the file holds no "deviations_um" or "teeth"');
      return data.deviations_um ? { deviations_um: data.deviations_um } : { teeth: data.teeth };
    }
    return { deviations_um: parseCsvGrid(text, rows, columns) };
  }

  // The closed loop by hand: the part ground with this job's corrected settings was measured;
  // its file (CSV grid, JSON measurement file, or a measuring machine's .mka / GDE file, chosen
  // or dropped on the panel) becomes a new correction linked to this job.
  function nextPartPanel(job) {
    const req = job.request || {};
    const bevel = P.isBevel(job);
    const input = P.html("input", { type: "file", accept: ".csv,.json,.mka,.xml,.gde,text/csv,application/json", id: "next-part-file" });
    const status = P.html("span", { class: "note", id: "next-part-status" });
    const panel = P.html("div", { class: "actions next-part" }, [
      P.html("label", { for: "next-part-file", text: "Next part, ground with these settings \u2014 its measurement (CSV, JSON, .mka, GDE; or drop it here):" }),
      input,
      status,
    ]);
    const submit = async (file) => {
      if (!file) return;
      status.className = "note";
      status.textContent = "reading " + file.name + "\u2026";
      try {
        const measurement = await readMeasurement(file, job);
        const request = {};
        for (const k of ["gear", "wheel", "machine", "grid", "flank", "job", "target", "options", "allow_large_deviations"]) if (req[k] !== undefined) request[k] = req[k];
        // A bevel pinion was cut with the corrected axis motions, a gear ground with the settings.
        if (bevel) request.motion = (job.result || {}).motion;
        else request.settings = (job.result || {}).settings;
        request.settings_source_job_id = job.id;
        request.measurement = measurement;
        status.textContent = "correcting\u2026";
        const created = await api("POST", "/api/v1/corrections", request);
        status.textContent = "job " + created.id + " stored";
        state.offset = 0;
        await loadJobs();
        window.location.hash = "job=" + created.id;
      } catch (e) {
        status.className = "error";
        status.textContent = file.name + ": " + e.message;
      }
    };
    input.addEventListener("change", () => submit(input.files && input.files[0]));
    panel.addEventListener("dragover", (e) => {
      e.preventDefault();
      panel.classList.add("dragging");
    });
    panel.addEventListener("dragleave", () => panel.classList.remove("dragging"));
    panel.addEventListener("drop", (e) => {
      e.preventDefault();
      panel.classList.remove("dragging");
      submit(e.dataTransfer && e.dataTransfer.files && e.dataTransfer.files[0]);
    });
    return panel;
  }

  // What a new job's answer says at a glance: status (and why), the predicted residual, the best
  // reachable and, with a tolerance, the verdicts of the measured and the predicted part.
  function answerSummary(created) {
    const r = created.result || {};
    const v = r.verdict || null;
    const part = (p) => (p ? p.verdict + (p.failed && p.failed.length ? " (misses " + p.failed.join(", ") + ")" : "") : "\u2013");
    const rows = [
      ["job", String(created.id) + " (" + created.kind + ")"],
      ["status", (created.status || r.status || "\u2013") + (r.message ? " \u2014 " + r.message : "")],
      ["measured rms / max", P.fmt(r.initial_rms_um, 3) + " / " + P.fmt(r.initial_max_um, 3) + " \u00b5m"],
      ["predicted residual rms / max", P.fmt(r.residual_rms_um, 3) + " / " + P.fmt(r.residual_max_um, 3) + " \u00b5m"],
      ["best reachable rms", P.fmt(r.best_reachable_rms_um, 3) + " \u00b5m"],
      ...P.nextPartRows(r),
    ];
    if (v) rows.push(["verdict measured", part(v.measured)], ["verdict predicted", part(v.predicted)]);
    const table = P.html("table", { class: "summary answer", "data-job-id": created.id });
    for (const [k, val] of rows) table.appendChild(P.html("tr", {}, [P.html("th", { text: k }), P.html("td", { text: val })]));
    const open = P.html("a", { href: "#job=" + created.id, class: "button", text: "Open job " + created.id });
    return P.html("div", { class: "answer-box" }, [table, open]);
  }

  // A new correction of the same gear and machine (job N's gear, wheel, machine, grid, flank,
  // target, options, tolerance and the settings its part was ground with) from another measured
  // part's file; the answer is shown here and the job joins the history.
  function newCorrectionPanel(job) {
    const req = job.request || {};
    const bevel = P.isBevel(job);
    const input = P.html("input", { type: "file", accept: ".csv,.json,.mka,.xml,.gde,text/csv,application/json", id: "new-correction-file" });
    const status = P.html("span", { class: "note", id: "new-correction-status" });
    const answer = P.html("div", { id: "new-correction-result" });
    input.addEventListener("change", async () => {
      const file = input.files && input.files[0];
      if (!file) return;
      status.className = "note";
      status.textContent = "reading " + file.name + "\u2026";
      answer.textContent = "";
      try {
        const request = { measurement: await readMeasurement(file, job) };
        for (const k of ["gear", "wheel", "machine", "grid", "flank", "job", "target", "options", "tolerance", "settings", "motion"]) if (req[k] !== undefined) request[k] = req[k];
        // The same part number and machine as job N's; this file's name (serial, time: another part).
        if (!bevel) {
          const was = job.trace || {};
          request.trace = { file_name: file.name.slice(0, 200) };
          for (const k of ["part_number", "machine_id"]) if (was[k]) request.trace[k] = was[k];
        }
        status.textContent = "correcting\u2026";
        const created = await api("POST", "/api/v1/corrections", request);
        status.textContent = "job " + created.id + " stored from " + file.name;
        answer.appendChild(answerSummary(created));
        state.offset = 0;
        await loadJobs();
        document.body.setAttribute("data-new-correction", String(created.id));
      } catch (e) {
        status.className = "error";
        status.textContent = file.name + ": " + e.message;
      } finally {
        input.value = "";
      }
    });
    return P.html("div", { class: "actions new-correction" }, [
      P.html("label", { for: "new-correction-file", text: "Correct again from job " + job.id + " (same gear, machine, target and settings) with a new measurement (CSV, JSON, .mka, GDE):" }),
      input,
      status,
      answer,
    ]);
  }

  const MODIFICATION_KINDS = ["profile_crowning", "lead_crowning", "profile_slope", "helix_slope", "tip_relief", "root_relief", "end_relief", "flank_twist", "diagonal_end_relief"];
  const RELIEFS = ["tip_relief", "root_relief", "end_relief", "diagonal_end_relief"];

  // One modification of the target being edited (MODEL.md section 7): kind, amount [um] and, for
  // a relief, its length fraction and shape (diagonal end relief: the second end too). Fields the
  // form does not show (amount gradients) are kept from the stored modification.
  function modificationRow(m, onRemove) {
    const kind = P.html("select", { class: "mod-kind", "aria-label": "kind" }, MODIFICATION_KINDS.map((k) => P.html("option", { value: k, text: k.replace(/_/g, " ") })));
    kind.value = MODIFICATION_KINDS.includes(m.kind) ? m.kind : "lead_crowning";
    const num = (cls, label, value, step, hint) => P.html("input", { type: "number", class: cls, "aria-label": label, title: label, step, placeholder: hint || "", value: value === undefined ? "" : String(value) });
    const amount = num("mod-amount", "amount_um", m.amount_um === undefined ? 0 : m.amount_um, "0.1");
    const length = num("mod-length", "length_fraction", m.length_fraction, "0.05", "0.2");
    const shape = P.html("select", { class: "mod-shape", "aria-label": "shape" }, ["linear", "parabolic"].map((v) => P.html("option", { value: v, text: v })));
    shape.value = m.shape || "linear";
    const second = num("mod-second-amount", "second_amount_um", m.second_amount_um, "0.1", "\u00b5m");
    const secondLength = num("mod-second-length", "second_length_fraction", m.second_length_fraction, "0.05", "length");
    const remove = P.html("button", { type: "button", class: "mod-remove", title: "remove", text: "\u00d7" });
    const row = P.html("div", { class: "mod-row" }, [kind, P.html("span", { text: "amount \u00b5m" }), amount, P.html("span", { class: "relief", text: "length" }), length, shape, P.html("span", { class: "diagonal", text: "2nd \u00b5m" }), second, secondLength, remove]);
    const relief = () => {
      const isRelief = RELIEFS.includes(kind.value);
      const diagonal = kind.value === "diagonal_end_relief";
      for (const el of row.querySelectorAll(".relief, .mod-length, .mod-shape")) el.hidden = !isRelief;
      for (const el of row.querySelectorAll(".diagonal, .mod-second-amount, .mod-second-length")) el.hidden = !diagonal;
    };
    kind.addEventListener("change", relief);
    relief();
    remove.addEventListener("click", () => onRemove(row));
    // The modification as the request schema has it; an Error names the field that is not a number.
    row.read = (index) => {
      const out = Object.assign({}, m, { kind: kind.value });
      const value = (input, name, required) => {
        if (input.hidden || (input.value.trim() === "" && !required)) return undefined;
        const v = Number(input.value);
        if (input.value.trim() === "" || !Number.isFinite(v)) throw new Error("target.modifications[" + index + "]." + name + ": not a number");
        return v;
      };
      const fields = [["amount_um", amount, true], ["length_fraction", length], ["second_amount_um", second], ["second_length_fraction", secondLength]];
      for (const [name, input, required] of fields) {
        const v = value(input, name, required);
        if (v === undefined) delete out[name];
        else out[name] = v;
      }
      if (RELIEFS.includes(kind.value)) out.shape = shape.value;
      else delete out.shape;
      return out;
    };
    return row;
  }

  // The job's target as modifications to edit, then either what the machine can make of it
  // (POST /api/v1/targets/reach, nothing stored) or a replay of the stored measurement with it
  // (POST .../replay {"target"}), which opens the new linked job.
  function targetEditor(job) {
    const req = job.request || {};
    const stored = (req.target || {}).modifications || [];
    const list = P.html("div", { class: "mod-list", id: "target-mods" });
    const removeRow = (row) => row.remove();
    for (const m of stored) list.appendChild(modificationRow(m, removeRow));
    const add = P.html("button", { type: "button", id: "target-add", text: "+ modification" });
    add.addEventListener("click", () => list.appendChild(modificationRow({ kind: "lead_crowning", amount_um: 0 }, removeRow)));
    const reach = P.html("button", { type: "button", class: "button", id: "reach-target", text: "What can the machine make of it?" });
    const replay = P.html("button", { type: "button", class: "button", id: "replay-target", text: "Replay with this target" });
    const status = P.html("span", { class: "note", id: "target-status" });
    const out = P.html("div", { id: "reach-result" });
    const target = () => ({ modifications: Array.from(list.querySelectorAll(".mod-row")).map((row, i) => row.read(i)) });
    const run = async (button, work) => {
      button.disabled = true;
      status.className = "note";
      status.textContent = "solving\u2026";
      try {
        await work(target());
        status.textContent = "";
      } catch (e) {
        status.className = "error";
        status.textContent = e.message;
      } finally {
        button.disabled = false;
      }
    };
    reach.addEventListener("click", () =>
      run(reach, async (t) => {
        const body = { target: t };
        for (const k of ["gear", "wheel", "machine", "grid", "flank", "settings", "options"]) if (req[k] !== undefined) body[k] = req[k];
        out.textContent = "";
        out.appendChild(reachTable(await api("POST", "/api/v1/targets/reach", body)));
      })
    );
    replay.addEventListener("click", () =>
      run(replay, async (t) => {
        const created = await api("POST", "/api/v1/corrections/" + job.id + "/replay", { target: t });
        state.offset = 0;
        await loadJobs();
        window.location.hash = "job=" + created.id;
      })
    );
    const t = req.target || {};
    const kind = t.deviations_um ? "a user grid" : t.shaving || t.stock_target_um ? "a shaving-cutter target" : null;
    const grid = kind ? " The stored target is " + kind + "; a replay from here replaces it with these modifications." : "";
    return P.html("details", { class: "target-editor", id: "target-editor" }, [
      P.html("summary", { text: "Target modifications (MODEL.md \u00a77): change them, see what the machine can make, replay" }),
      P.html("p", {
        class: "note",
        text: "Amounts in \u00b5m as MODEL.md \u00a77 defines them: a crowning or relief of C takes C off at its end (deviation \u2212C, material removed); slopes and twist are signed. They refer to the grid's extent (\u00b10.4 b by default), not the face width." + grid,
      }),
      list,
      P.html("div", { class: "actions" }, [add, reach, replay, status]),
      out,
    ]);
  }

  // The reach answer: per modification and together, the target rms, the part no correction at
  // the allowed orders can make and the share the machine can make.
  function reachTable(answer) {
    const table = P.html("table", { class: "delta reach" });
    table.appendChild(P.html("tr", {}, ["target", "target rms \u00b5m", "unreachable rms \u00b5m", "reachable share", "predicted residual rms \u00b5m"].map((h) => P.html("th", { text: h }))));
    const row = (name, r, cls) =>
      P.html("tr", { class: cls || "" }, [
        P.html("th", { text: name }),
        P.html("td", { text: P.fmt(r.target_rms_um, 3) }),
        P.html("td", { text: P.fmt(r.unreachable_rms_um, 3) }),
        P.html("td", { text: typeof r.reachable_share === "number" ? (100 * r.reachable_share).toFixed(1) + " %" : "\u2013" }),
        P.html("td", { text: P.fmt(r.predicted_residual_rms_um, 3) }),
      ]);
    for (const c of answer.components || []) table.appendChild(row(((c.modification || {}).kind || "?").replace(/_/g, " ") + " " + P.fmt((c.modification || {}).amount_um, 1), c));
    table.appendChild(row("together (" + (answer.status || "?") + ")", answer.combined || {}, "reach-combined"));
    if (answer.with_highest_orders && !answer.with_highest_orders.same_as_combined) table.appendChild(row("together, every axis to order " + (answer.with_highest_orders.default_max_order || 6), answer.with_highest_orders));
    return table;
  }

  // The flank's measured, target and predicted topography as oblique 3-D views.
  function flank3dSection(job) {
    const section = P.html("section", { class: "flank-3d" }, [P.html("h3", { text: "Flank topography in 3-D (\u00b5m, + = material left on; one vertical scale)" })]);
    section.appendChild(S.topography3d(job));
    return section;
  }

  // Commanded vs corrected axis motion over the roll range, from the job's settings listing
  // (GET .../settings?format=csv, sampled finely); drawn when it arrives.
  function motionSection(job, ticket) {
    const section = P.html("section", { class: "axis-motion-section" }, [P.html("h3", { text: "Axis motion over the roll range: commanded vs corrected" })]);
    const box = P.html("div", {}, [message("Loading the settings listing\u2026", "loading")]);
    section.appendChild(box);
    apiText("/api/v1/corrections/" + job.id + "/settings?format=csv&samples=41")
      .then((text) => {
        if (ticket !== state.ticket) return;
        const listing = S.parseSettingsCsv(text);
        box.textContent = "";
        if (!listing.names.length) box.appendChild(message("The listing holds no axis motion.", "note"));
        else box.appendChild(S.axisMotionCurves(listing, P.isBevel(job)));
        document.body.setAttribute("data-motion-shown", String(job.id));
      })
      .catch((e) => {
        if (ticket !== state.ticket) return;
        box.textContent = "";
        box.appendChild(message("No axis motion: " + e.message, "note"));
        document.body.setAttribute("data-motion-shown", String(job.id));
      });
    return section;
  }

  // A grid as CSV in the clients' format (clients/FORMATS.md): header L1..Ln, row 1 (root) first,
  // missing points empty.
  function gridCsv(grid) {
    const header = grid[0].map((_, c) => "L" + (c + 1)).join(",");
    return [header].concat(grid.map((row) => row.map((v) => (typeof v === "number" ? String(v) : "")).join(","))).join("\n") + "\n";
  }

  function downloadLink(name, text, type) {
    const url = URL.createObjectURL(new Blob([text], { type }));
    return P.html("a", { href: url, download: name, class: "button", text: name });
  }

  // The job's grids as CSV files and the whole job as JSON, for a spreadsheet or the CLI.
  function downloads(job) {
    const box = P.html("div", { class: "actions downloads" }, [P.html("span", { class: "note", text: "Download:" })]);
    const grids = [
      ["measured", P.measuredGrid(job)],
      ["target", P.targetGrid(job)],
      ["residual", (job.result || {}).predicted_residual_um],
    ];
    for (const [name, grid] of grids) {
      if (grid && grid.length) box.appendChild(downloadLink("job" + job.id + "-" + name + ".csv", gridCsv(grid), "text/csv"));
    }
    box.appendChild(downloadLink("job" + job.id + ".json", JSON.stringify(job, null, 2), "application/json"));
    // The GDE file of a grinder job (GET .../export?format=gde), fetched with the token.
    if (!P.isBevel(job)) {
      const gde = P.html("button", { type: "button", class: "button", id: "export-gde", text: "job" + job.id + ".gde.xml" });
      gde.addEventListener("click", async () => {
        const headers = token() ? { Authorization: "Bearer " + token() } : {};
        const res = await fetch("/api/v1/corrections/" + job.id + "/export?format=gde", { headers });
        const text = await res.text();
        if (!res.ok) {
          gde.replaceWith(message("GDE export refused: " + text));
          return;
        }
        const link = downloadLink("job" + job.id + ".gde.xml", text, "application/xml");
        gde.replaceWith(link);
        link.click();
      });
      box.appendChild(gde);
    }
    return box;
  }

  // A simulated closed loop with the job's gear, machine, grid, target and options: hidden
  // machine errors drawn at random (fixed seed), probe noise 0.2 um, three corrections.
  async function runClosedLoop(job, box, button) {
    const req = job.request || {};
    const scenario = {};
    for (const k of ["gear", "wheel", "machine", "grid", "flank", "target", "options", "allow_large_deviations"]) if (req[k] !== undefined) scenario[k] = req[k];
    scenario.random_hidden_errors = { seed: 7 };
    scenario.noise_um = 0.2;
    scenario.seed = 11;
    scenario.corrections = 3;
    button.disabled = true;
    box.textContent = "";
    box.appendChild(message("Simulating grind \u2192 measure \u2192 correct \u2026", "loading"));
    try {
      const run = await api("POST", "/api/v1/simulations/closed-loop", scenario);
      const its = run.iterations || [];
      const x = its.map((it, i) => (typeof it.part === "number" ? it.part : i + 1));
      box.textContent = "";
      box.appendChild(P.html("h3", { text: "Simulated closed loop (hidden machine errors, seed 7)" }));
      const chart = P.lineChart(
        [
          { name: "true rms", x, y: its.map((it) => it.true_rms_um), markers: true },
          { name: "measured rms", x, y: its.map((it) => it.measured_rms_um), markers: true, dashed: true },
          { name: "true max", x, y: its.map((it) => it.true_max_um), dashed: true },
        ],
        { title: "deviation from target per ground part", xLabel: "part", yLabel: "\u00b5m", xTicks: "integer", width: 560 }
      );
      chart.classList.add("closed-loop");
      box.appendChild(chart);
      if (run.message) box.appendChild(message(run.message, "note"));
    } catch (e) {
      box.textContent = "";
      box.appendChild(message("Simulation refused: " + e.message));
    } finally {
      button.disabled = false;
    }
  }

  // The published plunge-shaving case (SHAVING.md; clients/examples/shaving.json).
  const SHAVING_EXAMPLE = {
    work_gear: { teeth: 19, normal_module_mm: 6, normal_pressure_angle_deg: 20, helix_angle_deg: 9.91, hand: "right", face_width_mm: 75 },
    cutter: { teeth: 37, normal_module_mm: 6, normal_pressure_angle_deg: 20, helix_angle_deg: 15, hand: "left", face_width_mm: 78, tip_radius_mm: 120.9157, root_radius_mm: 107.1569 },
    diagonal_modification: { root_um: 20, tip_um: 20, root_band: 0.3, tip_band: 0.3, exponent: 2, root_slope: 0, tip_slope: 0 },
    wheel_check: { h_s_mm: 2, traverse_mm_per_rad: 0 },
  };

  // #shaving: the cutter target of a diagonally modified pinion (POST /api/v1/shaving/cutter-target),
  // from a request the user edits; the pinion modification and the cutter target side by side.
  function showShaving() {
    state.selected = null;
    state.ticket = (state.ticket || 0) + 1;
    document.body.removeAttribute("data-job-shown");
    document.body.removeAttribute("data-shaving-shown");
    const detail = $("detail");
    detail.textContent = "";
    detail.appendChild(P.html("h2", { text: "Plunge-shaving cutter target" }));
    const request = P.html("textarea", { id: "shaving-request", rows: 12, cols: 90, spellcheck: "false" });
    request.value = JSON.stringify(SHAVING_EXAMPLE, null, 2);
    const compute = P.html("button", { type: "button", id: "shaving-compute", text: "Compute the cutter target" });
    const out = P.html("div", { id: "shaving-result" });
    detail.appendChild(P.html("p", { class: "note", text: "The work gear (pinion), its diagonal modification and the cutter (SHAVING.md); the answer is the cutter flank that shaves that pinion, as the grinding target." }));
    detail.appendChild(request);
    detail.appendChild(P.html("div", { class: "actions" }, [compute]));
    detail.appendChild(out);
    compute.addEventListener("click", async () => {
      let body;
      try {
        body = JSON.parse(request.value);
      } catch (e) {
        out.textContent = "";
        out.appendChild(message("The request is not JSON: " + e.message));
        return;
      }
      compute.disabled = true;
      out.textContent = "";
      out.appendChild(message("Computing\u2026", "loading"));
      try {
        const answer = await api("POST", "/api/v1/shaving/cutter-target", body);
        out.textContent = "";
        out.appendChild(P.renderShaving(answer));
        document.body.setAttribute("data-shaving-shown", "1");
      } catch (e) {
        out.textContent = "";
        out.appendChild(message("Refused: " + e.message));
      } finally {
        compute.disabled = false;
      }
    });
  }

  // #job=ID shows that job; #shaving the shaving view; without either the newest job is shown.
  function route() {
    if (window.location.hash === "#shaving") return showShaving();
    const m = /job=(\d+)/.exec(window.location.hash);
    if (m) showJob(Number(m[1]));
    else if (state.newest !== null && state.newest !== undefined) showJob(state.newest);
  }

  function init() {
    $("token").value = token();
    $("token").addEventListener("change", () => {
      try {
        localStorage.setItem("gearloop.token", $("token").value);
      } catch (e) {
        /* private mode: the token lives for this page only */
      }
      loadHealth();
      loadJobs().then(() => {
        if (state.selected === null) route();
      });
    });
    $("refresh").addEventListener("click", loadJobs);
    $("filter-kind").addEventListener("change", () => {
      state.offset = 0;
      loadJobs();
    });
    $("filter-status").addEventListener("change", () => {
      state.offset = 0;
      loadJobs();
    });
    $("newer").addEventListener("click", () => {
      state.offset = Math.max(0, state.offset - PAGE);
      loadJobs();
    });
    $("older").addEventListener("click", () => {
      state.offset += PAGE;
      loadJobs();
    });
    window.addEventListener("hashchange", route);
    loadHealth();
    loadJobs().then(route);
    // The history follows new jobs from the other clients.
    setInterval(() => {
      if (!document.hidden) loadJobs();
    }, 15000);
  }

  init();
})();
