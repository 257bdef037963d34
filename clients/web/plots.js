// clients/web/plots.js: SVG plots of a correction job, shared by the dashboard (app.js) and the
// printable report (report.js, also inlined by `gearloop report`). No framework, no network.
//
//   const view = GearloopPlots.renderJob(job, lineage);   // a <section> element
//   document.body.appendChild(view);
//
// Grids follow the API (api/openapi.yaml): an array of rows, row 0 at the root side, each row
// from x < 0 to x > 0, in um, positive = material left on, null = no value. They are drawn as a
// person looks at a flank chart: profile vertical with the tip at the top, lead horizontal.
"use strict";

(function (global) {
  const SVG_NS = "http://www.w3.org/2000/svg";

  // Creates an SVG element with attributes and children (strings become text nodes).
  function svg(tag, attrs, children) {
    const node = document.createElementNS(SVG_NS, tag);
    for (const [k, v] of Object.entries(attrs || {})) node.setAttribute(k, String(v));
    for (const child of children || []) {
      node.appendChild(typeof child === "string" ? document.createTextNode(child) : child);
    }
    return node;
  }

  // Creates an HTML element the same way.
  function html(tag, attrs, children) {
    const node = document.createElement(tag);
    for (const [k, v] of Object.entries(attrs || {})) {
      if (k === "text") node.textContent = v;
      else node.setAttribute(k, String(v));
    }
    for (const child of children || []) {
      if (child === null || child === undefined) continue;
      node.appendChild(typeof child === "string" ? document.createTextNode(child) : child);
    }
    return node;
  }

  function isNum(v) {
    return typeof v === "number" && Number.isFinite(v);
  }

  // A number with fixed decimals; "\u2013" for no value; never "-0.00".
  function fmt(v, digits) {
    if (!isNum(v)) return "\u2013";
    const d = digits === undefined ? 2 : digits;
    const text = v.toFixed(d);
    return Number(text) === 0 ? (0).toFixed(d) : text;
  }

  // --- Colours: a diverging scale, blue = material removed (< 0), red = material left on (> 0),
  // white = on the designed flank. Symmetric about 0 so the sign reads at a glance.
  function colour(v, maxAbs) {
    if (!isNum(v)) return "#d9d9d9";
    const t = Math.max(-1, Math.min(1, maxAbs > 0 ? v / maxAbs : 0));
    const blue = [33, 102, 172];
    const red = [178, 24, 43];
    const end = t < 0 ? blue : red;
    const a = Math.abs(t);
    const c = [0, 1, 2].map((i) => Math.round(255 + (end[i] - 255) * a));
    return "rgb(" + c.join(",") + ")";
  }

  // Black text on light cells, white on dark ones (the numbers must stay readable).
  function textColour(v, maxAbs) {
    if (!isNum(v)) return "#555";
    return Math.abs(v) / (maxAbs || 1) > 0.6 ? "#fff" : "#111";
  }

  // A "nice" step for about `count` ticks over [lo, hi].
  function niceTicks(lo, hi, count) {
    if (!(hi > lo)) {
      const pad = Math.abs(lo) > 0 ? Math.abs(lo) * 0.1 : 1;
      lo -= pad;
      hi += pad;
    }
    const raw = (hi - lo) / Math.max(1, count);
    const mag = Math.pow(10, Math.floor(Math.log10(raw)));
    const step = [1, 2, 2.5, 5, 10].map((m) => m * mag).find((s) => s >= raw) || 10 * mag;
    // Ticks cover [lo, hi] entirely, so no point sits on the frame.
    const ticks = [];
    const first = Math.floor(lo / step + 1e-9);
    const last = Math.ceil(hi / step - 1e-9);
    for (let k = first; k <= last; ++k) {
      const v = k * step;
      ticks.push(Math.abs(v) < step * 1e-9 ? 0 : v);
    }
    return { lo: Math.min(lo, ticks[0]), hi: Math.max(hi, ticks[ticks.length - 1]), ticks, step };
  }

  function tickLabel(v, step) {
    const digits = Math.max(0, Math.min(6, -Math.floor(Math.log10(step) + 1e-9)));
    return v.toFixed(digits);
  }

  function gridMaxAbs(grids) {
    let m = 0;
    for (const g of grids) {
      for (const row of g || []) for (const v of row || []) if (isNum(v)) m = Math.max(m, Math.abs(v));
    }
    return m > 0 ? m : 1;
  }

  // A topography as a colour map with the value written in each cell.
  //   opts.title, opts.maxAbs (shared scale), opts.subtitle
  function heatmap(grid, opts) {
    opts = opts || {};
    const rows = (grid || []).length;
    const cols = rows ? grid[0].length : 0;
    const cw = 54;
    const ch = 30;
    const left = 58;
    const top = 34;
    const barW = 14;
    const width = left + cols * cw + 70;
    const height = top + rows * ch + 46;
    const maxAbs = opts.maxAbs || gridMaxAbs([grid]);
    const root = svg("svg", {
      class: "heatmap",
      viewBox: "0 0 " + width + " " + height,
      width: width,
      height: height,
      role: "img",
      "aria-label": (opts.title || "topography") + " in micrometres",
    });
    root.appendChild(svg("text", { x: left, y: 16, class: "plot-title" }, [opts.title || ""]));
    if (opts.subtitle) {
      root.appendChild(svg("text", { x: left, y: 29, class: "plot-subtitle" }, [opts.subtitle]));
    }
    for (let r = rows - 1; r >= 0; --r) {
      // Row rows-1 (tip) at the top, drawn (and read by a screen reader) first.
      const y = top + (rows - 1 - r) * ch;
      const label = r === rows - 1 ? "tip " + (r + 1) : r === 0 ? "root 1" : String(r + 1);
      root.appendChild(svg("text", { x: left - 6, y: y + ch / 2 + 4, class: "axis-label", "text-anchor": "end" }, [label]));
      for (let c = 0; c < cols; ++c) {
        const v = grid[r][c];
        const x = left + c * cw;
        const cell = svg("rect", {
          x: x,
          y: y,
          width: cw - 1,
          height: ch - 1,
          fill: colour(v, maxAbs),
          class: isNum(v) ? "cell" : "cell missing",
          "data-row": r,
          "data-column": c,
        });
        cell.appendChild(svg("title", {}, ["row " + (r + 1) + ", L" + (c + 1) + ": " + (isNum(v) ? v.toFixed(3) + " \u00b5m" : "no value")]));
        root.appendChild(cell);
        root.appendChild(
          svg("text", { x: x + cw / 2, y: y + ch / 2 + 4, class: "cell-value", "text-anchor": "middle", fill: textColour(v, maxAbs) }, [
            fmt(v, 2),
          ])
        );
      }
    }
    for (let c = 0; c < cols; ++c) {
      root.appendChild(
        svg("text", { x: left + c * cw + cw / 2, y: top + rows * ch + 14, class: "axis-label", "text-anchor": "middle" }, ["L" + (c + 1)])
      );
    }
    root.appendChild(
      svg("text", { x: left + (cols * cw) / 2, y: top + rows * ch + 32, class: "axis-title", "text-anchor": "middle" }, [
        "lead  (x < 0  \u2192  x > 0)",
      ])
    );
    root.appendChild(
      svg("text", { x: 12, y: top + (rows * ch) / 2, class: "axis-title", "text-anchor": "middle", transform: "rotate(-90 12 " + (top + (rows * ch) / 2) + ")" }, [
        "profile",
      ])
    );
    // Colour bar with ticks in um.
    const bx = left + cols * cw + 12;
    const steps = 40;
    const bh = rows * ch;
    for (let i = 0; i < steps; ++i) {
      const v = maxAbs - ((i + 0.5) * 2 * maxAbs) / steps;
      root.appendChild(svg("rect", { x: bx, y: top + (i * bh) / steps, width: barW, height: bh / steps + 0.5, fill: colour(v, maxAbs) }));
    }
    root.appendChild(svg("rect", { x: bx, y: top, width: barW, height: bh, fill: "none", stroke: "#888" }));
    const scale = niceTicks(-maxAbs, maxAbs, 4);
    for (const t of scale.ticks) {
      if (Math.abs(t) > maxAbs * 1.0001) continue;
      const ty = top + ((maxAbs - t) / (2 * maxAbs)) * bh;
      root.appendChild(svg("line", { x1: bx + barW, x2: bx + barW + 4, y1: ty, y2: ty, stroke: "#444" }));
      root.appendChild(svg("text", { x: bx + barW + 6, y: ty + 4, class: "tick-label" }, [tickLabel(t, scale.step)]));
    }
    root.appendChild(svg("text", { x: bx, y: top - 6, class: "tick-label" }, ["\u00b5m"]));
    return root;
  }

  const PALETTE = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#17becf", "#8c564b"];

  // A line chart. series: [{name, x: [...], y: [...], colour?, dashed?, markers?}]
  //   opts.title, opts.xLabel, opts.yLabel, opts.width, opts.height, opts.xTicks (integers only),
  //   opts.yZero (false: do not stretch the y range to 0)
  function lineChart(series, opts) {
    opts = opts || {};
    const width = opts.width || 460;
    const height = opts.height || 260;
    const m = { left: 62, right: 14, top: 30, bottom: 46 };
    const pw = width - m.left - m.right;
    const ph = height - m.top - m.bottom;
    let xs = [];
    let ys = [];
    for (const s of series) {
      xs = xs.concat(s.x.filter(isNum));
      ys = ys.concat(s.y.filter(isNum));
    }
    const root = svg("svg", { class: "chart", viewBox: "0 0 " + width + " " + height, width: width, height: height, role: "img", "aria-label": opts.title || "chart" });
    root.appendChild(svg("text", { x: m.left, y: 16, class: "plot-title" }, [opts.title || ""]));
    if (!xs.length || !ys.length) {
      root.appendChild(svg("text", { x: width / 2, y: height / 2, "text-anchor": "middle", class: "axis-label" }, ["no data"]));
      return root;
    }
    const xr = niceTicks(Math.min(...xs), Math.max(...xs), 5);
    // opts.yZero false: the y range is the data's own (absolute axis positions), else it holds 0.
    const yr = opts.yZero === false ? niceTicks(Math.min(...ys), Math.max(...ys), 5) : niceTicks(Math.min(0, ...ys), Math.max(0, ...ys), 5);
    if (opts.xTicks === "integer") {
      xr.ticks = xr.ticks.filter((t) => Math.abs(t - Math.round(t)) < 1e-9);
      xr.step = Math.max(1, xr.step);
    }
    const X = (v) => m.left + ((v - xr.lo) / (xr.hi - xr.lo || 1)) * pw;
    const Y = (v) => m.top + ph - ((v - yr.lo) / (yr.hi - yr.lo || 1)) * ph;
    for (const t of yr.ticks) {
      root.appendChild(svg("line", { x1: m.left, x2: m.left + pw, y1: Y(t), y2: Y(t), class: t === 0 ? "grid-zero" : "grid-line" }));
      root.appendChild(svg("text", { x: m.left - 6, y: Y(t) + 4, "text-anchor": "end", class: "tick-label" }, [tickLabel(t, yr.step)]));
    }
    for (const t of xr.ticks) {
      root.appendChild(svg("line", { x1: X(t), x2: X(t), y1: m.top + ph, y2: m.top + ph + 4, stroke: "#444" }));
      root.appendChild(svg("text", { x: X(t), y: m.top + ph + 16, "text-anchor": "middle", class: "tick-label" }, [tickLabel(t, xr.step)]));
    }
    root.appendChild(svg("rect", { x: m.left, y: m.top, width: pw, height: ph, fill: "none", stroke: "#888" }));
    root.appendChild(svg("text", { x: m.left + pw / 2, y: height - 8, "text-anchor": "middle", class: "axis-title" }, [opts.xLabel || ""]));
    const ym = m.top + ph / 2;
    root.appendChild(svg("text", { x: 14, y: ym, "text-anchor": "middle", class: "axis-title", transform: "rotate(-90 14 " + ym + ")" }, [opts.yLabel || ""]));
    let lx = m.left + 8;
    series.forEach((s, i) => {
      const col = s.colour || PALETTE[i % PALETTE.length];
      const pts = [];
      for (let k = 0; k < s.x.length; ++k) if (isNum(s.x[k]) && isNum(s.y[k])) pts.push([X(s.x[k]), Y(s.y[k])]);
      if (pts.length) {
        root.appendChild(
          svg("polyline", {
            points: pts.map((p) => p[0].toFixed(1) + "," + p[1].toFixed(1)).join(" "),
            fill: "none",
            stroke: col,
            "stroke-width": 2,
            "stroke-dasharray": s.dashed ? "5 4" : "none",
            class: "series",
            "data-name": s.name,
          })
        );
        if (s.markers) for (const p of pts) root.appendChild(svg("circle", { cx: p[0], cy: p[1], r: 3.5, fill: col }));
      }
      // Legend along the top of the plot area.
      root.appendChild(svg("line", { x1: lx, x2: lx + 16, y1: m.top + 10, y2: m.top + 10, stroke: col, "stroke-width": 2, "stroke-dasharray": s.dashed ? "5 4" : "none" }));
      const label = svg("text", { x: lx + 20, y: m.top + 14, class: "legend" }, [s.name]);
      root.appendChild(label);
      lx += 28 + 7 * s.name.length;
    });
    return root;
  }

  // --- Job data -------------------------------------------------------------------------------

  function measuredGrid(job) {
    const result = job.result || {};
    if (result.measured_um) return result.measured_um;
    const m = (job.request || {}).measurement || {};
    if (m.deviations_um) return m.deviations_um;
    if (!Array.isArray(m.teeth) || !m.teeth.length) return null;
    // The point-by-point mean of the teeth, as the server averages them.
    return m.teeth[0].map((row, r) =>
      row.map((_, c) => {
        const vals = m.teeth.map((t) => t[r][c]).filter(isNum);
        return vals.length ? vals.reduce((a, b) => a + b, 0) / vals.length : null;
      })
    );
  }

  // The designed topography: the server's grid (result.target_um); for a job stored before the
  // server sent it, the request's grid, or zero without a target. A target given as
  // modifications is the server's to evaluate: such an older job has no target grid here.
  function targetGrid(job) {
    const result = job.result || {};
    if (result.target_um) return result.target_um;
    const target = (job.request || {}).target;
    if (target && target.deviations_um) return target.deviations_um;
    if (target) return null;
    const meas = measuredGrid(job);
    return meas ? meas.map((row) => row.map(() => 0)) : null;
  }

  const AXES = ["X", "Y", "Z", "A", "B", "C"];

  // A spiral-bevel pinion job on the free-form generator (machine.kind of its request): its
  // motions are polynomials {A_rad, B_rad, X_mm, Y_mm, Z_mm} in the cradle roll t [rad].
  function isBevel(job) {
    const machine = ((job || {}).request || {}).machine || {};
    return machine.kind === "free-form-bevel-generator" || (job || {}).machine_kind === "free-form-bevel-generator";
  }
  const BEVEL_AXES = [["X", "X_mm"], ["Y", "Y_mm"], ["Z", "Z_mm"], ["A", "A_rad"], ["B", "B_rad"]];
  // A bevel motion change in the grinder's {axes: {X: [...]}} shape, for the same plots.
  function bevelAxes(delta) {
    const axes = {};
    for (const [a, key] of BEVEL_AXES) if (Array.isArray((delta || {})[key])) axes[a] = delta[key];
    return { axes: axes };
  }

  // The change of each axis motion over the roll range: sum_k delta_k * phi^k.
  function axisCurves(delta, rollRangeDeg, bevel) {
    const axes = (delta || {}).axes || {};
    const rollLabel = bevel ? "cradle roll t [deg]" : "roll angle \u03c6\u2081 [deg]";
    let lo = -10;
    let hi = 10;
    if (Array.isArray(rollRangeDeg) && isNum(rollRangeDeg[0]) && isNum(rollRangeDeg[1]) && rollRangeDeg[1] > rollRangeDeg[0]) {
      lo = rollRangeDeg[0];
      hi = rollRangeDeg[1];
    }
    const n = 60;
    const degs = [];
    for (let i = 0; i <= n; ++i) degs.push(lo + ((hi - lo) * i) / n);
    const curve = (coeffs, scale) =>
      degs.map((d) => {
        const phi = (d * Math.PI) / 180;
        let v = 0;
        let p = 1;
        for (const c of coeffs || []) {
          v += c * p;
          p *= phi;
        }
        return v * scale;
      });
    const linear = ["X", "Y", "Z"].map((a) => ({ name: a, x: degs, y: curve(axes[a], 1000) }));
    const rotaryNames = bevel ? ["A", "B"] : ["A", "B", "C"];
    const rotary = rotaryNames.map((a, i) => ({ name: a, x: degs, y: curve(axes[a], 1e6), colour: PALETTE[i + 3] }));
    const box = html("div", { class: "chart-row" });
    box.appendChild(lineChart(linear, { title: "linear axes: change X, Y, Z", xLabel: rollLabel, yLabel: "\u0394 [\u00b5m]" }));
    box.appendChild(lineChart(rotary, { title: "rotary axes: change " + rotaryNames.join(", "), xLabel: rollLabel, yLabel: "\u0394 [\u00b5rad]" }));
    return box;
  }

  // Residual along a chain of jobs (each ground with the settings of the one before it).
  function convergence(lineage) {
    const jobs = (lineage || []).slice().sort((a, b) => a.id - b.id);
    const x = jobs.map((_, i) => i + 1);
    const series = [
      { name: "measured rms", x: x, y: jobs.map((j) => (j.result ? j.result.initial_rms_um : j.initial_rms_um)), markers: true },
      { name: "predicted residual rms", x: x, y: jobs.map((j) => (j.result ? j.result.residual_rms_um : j.residual_rms_um)), markers: true, dashed: true },
      { name: "best reachable", x: x, y: jobs.map((j) => (j.result ? j.result.best_reachable_rms_um : j.best_reachable_rms_um)), dashed: true },
    ].filter((s) => s.y.some(isNum));
    const chart = lineChart(series, {
      title:
        jobs.length > 1
          ? "closed loop: deviation per correction (jobs " + jobs.map((j) => j.id).join(", ") + ")"
          : "job " + (jobs[0] ? jobs[0].id : "?") + ": no linked settings revisions yet (one correction)",
      xLabel: "correction in the loop",
      yLabel: "rms [\u00b5m]",
      xTicks: "integer",
      width: 560,
    });
    chart.classList.add("convergence");
    return chart;
  }

  // The traceability of a job (part, serial, teeth, measuring time and file, machine, batch,
  // submitter): one row per given field.
  function traceRows(trace) {
    if (!trace) return [];
    const labels = [
      ["part_number", "part number"], ["serial", "serial"], ["teeth", "measured teeth"],
      ["measured_at", "measured at"], ["file_name", "measuring file"], ["machine_id", "machine"],
      ["batch_id", "batch"], ["submitted_by", "submitted by"],
    ];
    const rows = [];
    for (const [key, label] of labels) {
      if (trace[key] === undefined || trace[key] === null) continue;
      rows.push([label, Array.isArray(trace[key]) ? trace[key].join(", ") : String(trace[key])]);
    }
    return rows;
  }

  // The tolerance and the PASS/FAIL of the measured and the predicted part (a job with a tolerance).
  function verdictRows(verdict) {
    if (!verdict) return [];
    const t = verdict.tolerance || {};
    const limits = [];
    if (t.rms_um !== undefined) limits.push("rms " + fmt(t.rms_um, 2) + " \u00b5m");
    if (t.max_um !== undefined) limits.push("max " + fmt(t.max_um, 2) + " \u00b5m");
    if (t.iso_class !== undefined) limits.push("ISO 1328-1 class " + t.iso_class);
    const part = (v) => (v ? v.verdict + (v.failed && v.failed.length ? " (misses " + v.failed.join(", ") + ")" : "") : "\u2013");
    return [
      ["tolerance", limits.join(", ")],
      ["verdict measured", part(verdict.measured)],
      ["verdict predicted", part(verdict.predicted)],
    ];
  }

  // How sure the prediction is (the answer's prediction_band) and, where the safe step kept less
  // than the whole change, how much and why; nothing for a job stored before them.
  function nextPartRows(r) {
    const rows = [];
    const b = (r || {}).prediction_band;
    if (b && isNum(b.expected_true_rms_um)) {
      const band = b.true_rms_2sigma_um || [];
      rows.push([
        "next part true rms (2\u03c3 band)",
        fmt(b.expected_true_rms_um, 3) + " \u00b5m (" + fmt(band[0], 3) + " \u2013 " + fmt(band[1], 3) + " \u00b5m; noise " +
          fmt(b.noise_sigma_um, 3) + " \u00b5m " + (b.noise_stated ? "stated" : "estimated") +
          (isNum(b.stated_noise_um)
            ? " from the measurement's scatter; " + fmt(b.stated_noise_um, 3) + " \u00b5m stated is contradicted"
            : "") +
          (b.misfit_read_as_flank && isNum(b.noise_read_as_probe_um)
            ? " from a misfit, more than a probe scatters: the expected value counts all but " +
              fmt(b.noise_read_as_probe_um, 3) + " \u00b5m of it as flank the next part keeps"
            : "") + ")",
      ]);
    }
    const s = (r || {}).safe_step;
    if (s && s.shortened_because) {
      rows.push(["safe step", "kept " + String(s.step_fraction) + " of the change: the whole change " + s.shortened_because]);
    }
    const p = s && s.wheel_parabola;
    if (p) {
      rows.push([
        "wheel parabola (rms of flank)",
        p.source === "measurement"
          ? fmt(p.estimate_flank_um, 3) + " \u00b1 " + fmt(p.sd_flank_um, 3) + " \u00b5m as the measurement shows it"
          : fmt(p.hedged_flank_um, 3) + " \u00b5m assumed (noise not known)",
      ]);
    }
    return rows;
  }

  // What the exact-model search did and, when it ran, its two exact predictions; "\u2013" for a
  // job stored before it (or a solver without it).
  function exactSearchRows(search) {
    const s = search || {};
    const rows = [["exact-model search", s.outcome || "\u2013"]];
    if (isNum(s.regularised_predicted_rms_um) || isNum(s.searched_predicted_rms_um)) {
      rows.push(["exact-model rms regularised / searched", fmt(s.regularised_predicted_rms_um, 3) + " / " + fmt(s.searched_predicted_rms_um, 3) + " \u00b5m"]);
    }
    return rows;
  }

  function summaryTable(job) {
    const r = job.result || {};
    const req = job.request || {};
    const gear = req.gear || job.gear || {};
    const bevelJob = req.job || {};
    const setupRows = isBevel(job)
      ? [
          ["machine", "free-form bevel generator"],
          ["part", "spiral bevel pinion, " + (bevelJob.side || job.flank || "?") + " flank" + (bevelJob.published ? " (published summary)" : "")],
        ]
      : null;
    const rows = [
      ["job", job.id + " (" + (job.kind || "correction") + ")"],
      ["created", job.created_utc || "\u2013"],
      ["gear", (gear.teeth || "?") + " teeth, m\u2099 " + (gear.normal_module_mm || "?") + " mm, \u03b1\u2099 " + fmt(gear.normal_pressure_angle_deg, 1) + "\u00b0, \u03b2 " + fmt(gear.helix_angle_deg, 1) + "\u00b0 " + (gear.hand || "")],
      ["flank", req.flank || job.flank || "right"],
      ["status", (r.status || job.status || "\u2013") + (r.message ? " \u2014 " + r.message : "")],
      ["measured rms / max", fmt(r.initial_rms_um, 3) + " / " + fmt(r.initial_max_um, 3) + " \u00b5m"],
      ["predicted residual rms / max", fmt(r.residual_rms_um, 3) + " / " + fmt(r.residual_max_um, 3) + " \u00b5m"],
      ["best reachable rms", fmt(r.best_reachable_rms_um, 3) + " \u00b5m"],
      ...nextPartRows(r),
      ["solver, mode", (r.solver || "\u2013") + ", " + (r.mode || "\u2013")],
      ["rank, condition", (r.rank === undefined ? "\u2013" : r.rank) + ", " + fmt(r.condition_number, 1)],
      ["regularisation", r.regularisation ? r.regularisation.rule + " " + fmt(r.regularisation.level, 4) : "\u2013"],
      ["linearised at", !r.machine_state ? "\u2013" : r.machine_state.estimated
        ? "estimated machine state (size " + fmt(r.machine_state.size, 1) + ", misfit rms " + fmt(r.machine_state.misfit_rms_um, 3) + " \u00b5m)"
        : "commanded settings"],
      ...exactSearchRows(r.exact_search),
      ["iterations, time", (r.iterations === undefined ? "\u2013" : r.iterations) + ", " + fmt(r.elapsed_ms, 1) + " ms"],
    ];
    if (setupRows) rows.splice(2, 2, ...setupRows);
    if (job.parent_job_id) rows.push(["replay of job", String(job.parent_job_id)]);
    if (job.settings_source_job_id) rows.push(["ground with settings of job", String(job.settings_source_job_id)]);
    rows.push(...verdictRows(r.verdict));
    rows.push(...traceRows(job.trace));
    const table = html("table", { class: "summary" });
    for (const [k, v] of rows) table.appendChild(html("tr", {}, [html("th", { text: k }), html("td", { text: v })]));
    return table;
  }

  // The change of each bevel axis polynomial, coefficient k of t^k.
  function bevelDeltaTable(delta) {
    const degree = ((delta || {}).A_rad || []).length;
    const table = html("table", { class: "delta" });
    const head = html("tr", {}, [html("th", { text: "axis" })]);
    for (let k = 0; k < degree; ++k) head.appendChild(html("th", { text: "\u00d7 t^" + k }));
    table.appendChild(head);
    for (const [a, key] of BEVEL_AXES) {
      const tr = html("tr", {}, [html("th", { text: a + (key.endsWith("_mm") ? " [mm]" : " [rad]") })]);
      for (let k = 0; k < degree; ++k) {
        const v = ((delta || {})[key] || [])[k];
        tr.appendChild(html("td", { text: isNum(v) ? v.toExponential(3) : "0" }));
      }
      table.appendChild(tr);
    }
    return html("div", {}, [table]);
  }

  function deltaTable(delta) {
    const axes = (delta || {}).axes || {};
    const table = html("table", { class: "delta" });
    const head = html("tr", {}, [html("th", { text: "axis" })]);
    for (let k = 0; k < 7; ++k) head.appendChild(html("th", { text: "\u00d7 \u03c6^" + k }));
    table.appendChild(head);
    for (const a of AXES) {
      const tr = html("tr", {}, [html("th", { text: a + (["X", "Y", "Z"].includes(a) ? " [mm]" : " [rad]") })]);
      for (let k = 0; k < 7; ++k) {
        const v = (axes[a] || [])[k];
        tr.appendChild(html("td", { text: isNum(v) ? v.toExponential(3) : "0" }));
      }
      table.appendChild(tr);
    }
    const w = (delta || {}).wheel || {};
    const wheel = html("p", { class: "wheel-delta", text: "wheel: cone angle " + fmt(w.cone_angle_deg, 6) + "\u00b0, parabola " + (isNum(w.parabola_coefficient_per_mm) ? w.parabola_coefficient_per_mm.toExponential(3) : "0") + " /mm, vertex " + fmt(w.parabola_vertex_mm, 4) + " mm" });
    return html("div", {}, [table, wheel]);
  }

  // The correction as machine motion (result.axis_motion): the change of each axis position at
  // the roll angles of the range (um for linear axes, urad for rotary ones), its rms and largest
  // magnitude over the range, and the wheel-parameter changes. Null for a job stored without it.
  function axisMotionTable(motion) {
    if (!motion || !Array.isArray(motion.roll_rad) || !motion.roll_rad.length) return null;
    const axes = motion.axes || {};
    const names = ["X", "Y", "Z", "A", "B", "C"].filter((a) => axes[a]).concat(Object.keys(axes).filter((a) => !AXES.includes(a)));
    const table = html("table", { class: "delta axis-motion" });
    const head = html("tr", {}, [html("th", { text: "roll [\u00b0]" })]);
    for (const r of motion.roll_rad) head.appendChild(html("th", { text: isNum(r) ? ((r * 180) / Math.PI).toFixed(2) : "\u2013" }));
    head.appendChild(html("th", { text: "rms" }));
    head.appendChild(html("th", { text: "max |\u0394|" }));
    table.appendChild(head);
    for (const a of names) {
      const m = axes[a] || {};
      const unit = m.change_um ? "um" : m.change_urad ? "urad" : null;
      if (!unit) continue;
      const tr = html("tr", { "data-axis": a }, [html("th", { text: a + (unit === "um" ? " [\u00b5m]" : " [\u00b5rad]") })]);
      for (const v of m["change_" + unit]) tr.appendChild(html("td", { text: fmt(v, 2) }));
      tr.appendChild(html("td", { text: fmt(m["rms_" + unit], 2) }));
      tr.appendChild(html("td", { text: fmt(m["max_abs_" + unit], 2) }));
      table.appendChild(tr);
    }
    const box = html("div", {}, [html("p", { class: "note", text: "Axis motion of the correction: change of each axis position over the roll range." }), table]);
    const wheel = Object.entries(motion.wheel || {});
    if (wheel.length) {
      box.appendChild(html("p", { class: "wheel-delta", text: "wheel change: " + wheel.map(([k, v]) => k + " " + (isNum(v) ? v.toPrecision(4) : "\u2013")).join(", ") }));
    }
    return box;
  }

  // ISO 1328-1 figures (um) and accuracy classes of a grinder result (result.iso1328,
  // shared/design/METROLOGY.md section 4): the measured flank, the measured flank against the
  // target and the predicted next part against the target. Null for a job without them (a bevel
  // job, or one stored before they were computed).
  const ISO_ROWS = [
    ["f_H\u03b1 slope", "fHa_mean", "fHa"],
    ["f_f\u03b1 form", "ffa_max_abs", "ffa"],
    ["F_\u03b1 total", "Fa_max_abs", "Fa"],
    ["C_\u03b1 crowning", "Ca_mean", null],
    ["f_H\u03b2 slope", "fHb_mean", "fHb"],
    ["f_f\u03b2 form", "ffb_max_abs", "ffb"],
    ["F_\u03b2 total", "Fb_max_abs", "Fb"],
    ["C_\u03b2 crowning", "Cb_mean", null],
    ["twist S_\u03b1", "twist_alpha", null],
    ["twist S_\u03b2", "twist_beta", null],
  ];
  function isoTable(iso) {
    if (!iso || typeof iso !== "object") return null;
    const flanks = [
      ["measured", iso.measured],
      ["vs target", iso.target_relative],
      ["predicted", iso.predicted],
    ];
    const table = html("table", { class: "delta iso1328" });
    const head = html("tr", {}, [html("th", { text: "ISO 1328-1 [\u00b5m]" })]);
    for (const [name] of flanks) {
      head.appendChild(html("th", { text: name }));
      head.appendChild(html("th", { text: "cl.", title: "ISO 1328-1 accuracy class (1..11)" }));
    }
    table.appendChild(head);
    const cls = (q, key) => {
      const v = q && q.classes ? q.classes[key] : undefined;
      return isNum(v) ? String(v) : v === null ? ">11" : "";
    };
    for (const [label, figure, klass] of ISO_ROWS) {
      const tr = html("tr", { "data-figure": figure }, [html("th", { text: label })]);
      for (const [, q] of flanks) {
        tr.appendChild(html("td", { text: q && q.figures ? fmt(q.figures[figure], 2) : "\u2013" }));
        tr.appendChild(html("td", { class: "iso-class", text: klass ? cls(q, klass) : "" }));
      }
      table.appendChild(tr);
    }
    const overall = html("tr", { "data-figure": "overall", class: "iso-overall" }, [html("th", { text: "overall class" })]);
    for (const [, q] of flanks) {
      overall.appendChild(html("td", { text: "" }));
      overall.appendChild(html("td", { class: "iso-class", text: cls(q, "overall") }));
    }
    table.appendChild(overall);
    const notes = flanks.filter(([, q]) => q && q.message).map(([name, q]) => name + ": " + q.message);
    const box = html("div", { class: "iso-box" }, [table]);
    box.appendChild(html("p", { class: "note", text: "Slopes: mean over the traces; crowning, twist referred to L\u03b1, L\u03b2; form, total and classes: worst trace." }));
    for (const n of notes) box.appendChild(html("p", { class: "note", text: n }));
    return box;
  }

  // --- Split bevel trajectory (kind "split_trajectory", docs/split-bevel.md) ------------------

  // A 5-axis flank-milling trajectory of a split bevel wheel: its result holds passes of points,
  // not grids.
  function isSplitTrajectory(job) {
    return (job || {}).kind === "split_trajectory" || (job || {}).machine_kind === "head-head-5-axis-mill";
  }

  const FLANK_COLOUR = { convex: "#1f77b4", concave: "#d62728" };

  // A point and a direction of the blank frame in machine coordinates: blank_to_machine is the
  // 4 x 4 row-major [M, apex; 0 0 0 1] of the result.
  function toMachine(t, v, isPoint) {
    const out = [0, 1, 2].map((i) => t[4 * i] * v[0] + t[4 * i + 1] * v[1] + t[4 * i + 2] * v[2] + (isPoint ? t[4 * i + 3] : 0));
    return out;
  }

  // One orthographic projection of the tool-centre paths with the tool axes drawn as segments at
  // about ten stations of each pass, on one scale for both coordinates (the shape is true).
  //   paths: [{flank, points: [[u, v]], axes: [[u0, v0, u1, v1]]}]; opts.title, uLabel, vLabel, subtitle
  function pathProjection(paths, opts) {
    const width = opts.width || 430;
    const height = opts.height || 400;
    const m = { left: 64, right: 14, top: 44, bottom: 46 };
    const pw = width - m.left - m.right;
    const ph = height - m.top - m.bottom;
    const us = [];
    const vs = [];
    for (const p of paths) {
      for (const q of p.points) us.push(q[0]), vs.push(q[1]);
      for (const a of p.axes) us.push(a[0], a[2]), vs.push(a[1], a[3]);
    }
    const root = svg("svg", { class: "chart split-projection", viewBox: "0 0 " + width + " " + height, width: width, height: height, role: "img", "aria-label": opts.title });
    root.appendChild(svg("text", { x: m.left, y: 16, class: "plot-title" }, [opts.title]));
    if (opts.subtitle) root.appendChild(svg("text", { x: m.left, y: 30, class: "plot-subtitle" }, [opts.subtitle]));
    if (!us.length) return root;
    // One scale: the larger span fills its side, the other is centred.
    const uMid = (Math.min(...us) + Math.max(...us)) / 2;
    const vMid = (Math.min(...vs) + Math.max(...vs)) / 2;
    const scale = Math.min(pw / (Math.max(...us) - Math.min(...us) || 1), ph / (Math.max(...vs) - Math.min(...vs) || 1)) * 0.92;
    const U = (u) => m.left + pw / 2 + (u - uMid) * scale;
    const V = (v) => m.top + ph / 2 - (v - vMid) * scale;
    const ur = niceTicks(uMid - pw / 2 / scale, uMid + pw / 2 / scale, 4);
    const vr = niceTicks(vMid - ph / 2 / scale, vMid + ph / 2 / scale, 4);
    for (const t of ur.ticks) {
      if (U(t) < m.left || U(t) > m.left + pw) continue;
      root.appendChild(svg("line", { x1: U(t), x2: U(t), y1: m.top, y2: m.top + ph, class: "grid-line" }));
      root.appendChild(svg("text", { x: U(t), y: m.top + ph + 16, "text-anchor": "middle", class: "tick-label" }, [tickLabel(t, ur.step)]));
    }
    for (const t of vr.ticks) {
      if (V(t) < m.top || V(t) > m.top + ph) continue;
      root.appendChild(svg("line", { x1: m.left, x2: m.left + pw, y1: V(t), y2: V(t), class: "grid-line" }));
      root.appendChild(svg("text", { x: m.left - 6, y: V(t) + 4, "text-anchor": "end", class: "tick-label" }, [tickLabel(t, vr.step)]));
    }
    root.appendChild(svg("rect", { x: m.left, y: m.top, width: pw, height: ph, fill: "none", stroke: "#888" }));
    root.appendChild(svg("text", { x: m.left + pw / 2, y: height - 8, "text-anchor": "middle", class: "axis-title" }, [opts.uLabel]));
    const ym = m.top + ph / 2;
    root.appendChild(svg("text", { x: 14, y: ym, "text-anchor": "middle", class: "axis-title", transform: "rotate(-90 14 " + ym + ")" }, [opts.vLabel]));
    for (const p of paths) {
      const col = FLANK_COLOUR[p.flank] || "#555";
      for (const a of p.axes) {
        root.appendChild(svg("line", { x1: U(a[0]).toFixed(1), y1: V(a[1]).toFixed(1), x2: U(a[2]).toFixed(1), y2: V(a[3]).toFixed(1), stroke: col, "stroke-opacity": 0.45, class: "tool-axis" }));
      }
      root.appendChild(
        svg("polyline", {
          points: p.points.map((q) => U(q[0]).toFixed(1) + "," + V(q[1]).toFixed(1)).join(" "),
          fill: "none",
          stroke: col,
          "stroke-width": 1.5,
          class: "series tool-path",
          "data-name": p.flank + " " + p.level,
        })
      );
    }
    let lx = m.left + 8;
    for (const flank of ["convex", "concave"]) {
      if (!paths.some((p) => p.flank === flank)) continue;
      root.appendChild(svg("line", { x1: lx, x2: lx + 16, y1: m.top + 10, y2: m.top + 10, stroke: FLANK_COLOUR[flank], "stroke-width": 2 }));
      root.appendChild(svg("text", { x: lx + 20, y: m.top + 14, class: "legend" }, [flank]));
      lx += 80;
    }
    return root;
  }

  // The tool-centre paths and tool axes of every pass in machine coordinates, projected onto the
  // machine's X-Y (plan) and X-Z (front) planes.
  function splitProjections(result) {
    const t = ((result.setup || {}).blank_to_machine || []).length === 16 ? result.setup.blank_to_machine : [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1];
    const passes = result.passes || [];
    let extent = 0;
    const machine = passes.map((pass) => (pass.points || []).map((q) => ({ o: toMachine(t, q.tool_centre_mm, true), a: toMachine(t, q.tool_axis, false) })));
    for (const pts of machine) for (const q of pts) extent = Math.max(extent, Math.abs(q.o[0] - machine[0][0].o[0]), Math.abs(q.o[1] - machine[0][0].o[1]), Math.abs(q.o[2] - machine[0][0].o[2]));
    // Axis segments of a round length near a quarter of the paths' extent.
    const axisLength = niceTicks(0, Math.max(1, extent * 0.25), 1).step;
    const box = html("div", { class: "chart-row split-paths" });
    for (const [i, j, name] of [[0, 1, "plan X\u2013Y"], [0, 2, "front X\u2013Z"]]) {
      const paths = passes.map((pass, k) => {
        const pts = machine[k];
        const every = Math.max(1, Math.ceil(pts.length / 10));
        const axes = pts.filter((_, n) => n % every === 0 || n === pts.length - 1).map((q) => [q.o[i], q.o[j], q.o[i] + axisLength * q.a[i], q.o[j] + axisLength * q.a[j]]);
        return { flank: pass.flank, level: pass.level, points: pts.map((q) => [q.o[i], q.o[j]]), axes };
      });
      box.appendChild(
        pathProjection(paths, {
          title: "tool-centre paths, " + name,
          subtitle: "machine coordinates; tool axes drawn " + axisLength + " mm long, tip \u2192 spindle",
          uLabel: "XYZ"[i] + " [mm]",
          vLabel: "XYZ"[j] + " [mm]",
        })
      );
    }
    return box;
  }

  // A and B along the face (pitch-line arc length from the toe), one curve per flank (A and B
  // follow the tool axis, the flank ruling, which every depth level shares).
  function splitAngleCurves(result) {
    const firstOfFlank = {};
    for (const pass of result.passes || []) if (!firstOfFlank[pass.flank]) firstOfFlank[pass.flank] = pass;
    const box = html("div", { class: "chart-row split-angles" });
    for (const axis of ["A", "B"]) {
      const series = Object.values(firstOfFlank).map((pass) => ({
        name: axis + " " + pass.flank,
        x: pass.points.map((q) => q.arc_mm),
        y: pass.points.map((q) => q[axis + "_deg"]),
        colour: FLANK_COLOUR[pass.flank],
      }));
      box.appendChild(lineChart(series, { title: axis + " along the face", xLabel: "pitch-line arc from the toe [mm]", yLabel: axis + " [\u00b0]", width: 430 }));
    }
    return box;
  }

  function rangeText(values, digits) {
    const v = values.filter(isNum);
    return v.length ? fmt(Math.min(...v), digits) + " \u2026 " + fmt(Math.max(...v), digits) : "\u2013";
  }

  // Per pass: flank, level, stations, tool tip height, A and B ranges, side deviation.
  function splitPassTable(result) {
    const table = html("table", { class: "delta split-passes" });
    table.appendChild(html("tr", {}, ["pass", "flank", "level", "stations", "tip height [mm]", "A [\u00b0]", "B [\u00b0]", "side deviation [mm]"].map((h) => html("th", { text: h }))));
    (result.passes || []).forEach((pass, k) => {
      const pts = pass.points || [];
      const dev = pass.side_deviation_mm || {};
      table.appendChild(
        html("tr", { "data-pass": k + 1 }, [
          html("td", { text: String(k + 1) }),
          html("td", { text: pass.flank }),
          html("td", { text: String(pass.level) }),
          html("td", { text: String(pts.length) }),
          html("td", { text: fmt(pass.tip_height_mm, 3) }),
          html("td", { text: rangeText(pts.map((q) => q.A_deg), 3) }),
          html("td", { text: rangeText(pts.map((q) => q.B_deg), 3) }),
          html("td", { text: fmt(dev.min, 4) + " \u2026 " + fmt(dev.max, 4) }),
        ])
      );
    });
    return table;
  }

  function renderSplitTrajectory(job) {
    const r = job.result || {};
    const d = r.derived || {};
    const gear = (job.request || {}).gear || {};
    const section = html("section", { class: "job-view split-trajectory", "data-job-id": job.id });
    section.appendChild(html("h2", { text: "Job " + job.id }));
    const points = (r.passes || []).reduce((n, p) => n + (p.points || []).length, 0);
    const rows = [
      ["job", job.id + " (split_trajectory)"],
      ["created", job.created_utc || "\u2013"],
      ["machine", "head-head 5-axis mill (X Y Z A B), split bevel wheel segment"],
      ["gear", (gear.teeth || "?") + " teeth, \u03b4 " + fmt(gear.pitch_angle_deg, 2) + "\u00b0, " + (gear.hand || "?") + " hand, \u03b1 " + fmt(gear.pressure_angle_deg, 1) + "\u00b0"],
      ["base circle, normal module", fmt(d.base_radius_mm, 3) + " mm, " + fmt(d.normal_module_mm, 4) + " mm"],
      ["cone distance", fmt(d.inner_cone_distance_mm, 2) + " \u2026 " + fmt(d.outer_cone_distance_mm, 2) + " mm"],
      ["spiral angle", fmt(d.inner_spiral_angle_deg, 3) + " \u2026 " + fmt(d.outer_spiral_angle_deg, 3) + "\u00b0"],
      ["passes, points", (r.passes || []).length + ", " + points],
      ["time", fmt(job.elapsed_ms, 1) + " ms"],
    ];
    const table = html("table", { class: "summary" });
    for (const [k, v] of rows) table.appendChild(html("tr", {}, [html("th", { text: k }), html("td", { text: v })]));
    section.appendChild(table);
    section.appendChild(html("h3", { text: "Tool-centre paths and tool axes" }));
    section.appendChild(splitProjections(r));
    section.appendChild(html("h3", { text: "Head angles along the face" }));
    section.appendChild(splitAngleCurves(r));
    section.appendChild(html("h3", { text: "Passes" }));
    section.appendChild(splitPassTable(r));
    return section;
  }

  // The whole view of one job: summary, three topographies on one colour scale with the ISO
  // 1328-1 figures beside them, the axis corrections and the convergence of its lineage.
  function renderJob(job, lineage) {
    if (isSplitTrajectory(job)) return renderSplitTrajectory(job);
    const r = job.result || {};
    const measured = measuredGrid(job);
    const target = targetGrid(job);
    const residual = r.predicted_residual_um || null;
    const maxAbs = gridMaxAbs([measured, target, residual]);
    const section = html("section", { class: "job-view", "data-job-id": job.id });
    section.appendChild(html("h2", { text: "Job " + job.id }));
    section.appendChild(summaryTable(job));
    section.appendChild(html("h3", { text: "Topographies (\u00b5m, + = material left on; one colour scale)" }));
    const maps = html("div", { class: "chart-row maps" });
    // The ISO figures follow the measured map, so they sit beside it on a narrow page too.
    const iso = isoTable(r.iso1328);
    if (measured) maps.appendChild(heatmap(measured, { title: "measured", maxAbs: maxAbs }));
    if (iso) maps.appendChild(iso);
    if (target) maps.appendChild(heatmap(target, { title: "target", maxAbs: maxAbs }));
    if (residual) maps.appendChild(heatmap(residual, { title: "predicted residual", maxAbs: maxAbs }));
    section.appendChild(maps);
    const absent = [["measured", measured], ["target", target], ["predicted residual", residual]].filter((e) => !e[1]).map((e) => e[0]);
    if (absent.length) section.appendChild(html("p", { class: "note", text: "Not stored with this job: " + absent.join(", ") + "." }));
    section.appendChild(html("h3", { text: "Axis corrections over the roll range" }));
    if (isBevel(job)) {
      section.appendChild(html("p", { class: "machine-kind", text: "machine: free-form bevel generator (grid rows root to face, columns toe to heel)" }));
      section.appendChild(axisCurves(bevelAxes(r.delta), r.roll_range_deg, true));
      section.appendChild(bevelDeltaTable(r.delta));
    } else {
      section.appendChild(axisCurves(r.delta, r.roll_range_deg));
      section.appendChild(deltaTable(r.delta));
    }
    const motionTable = axisMotionTable(r.axis_motion);
    if (motionTable) section.appendChild(motionTable);
    section.appendChild(html("h3", { text: "Convergence" }));
    section.appendChild(convergence(lineage && lineage.length ? lineage : [job]));
    return section;
  }

  // POST /api/v1/shaving/cutter-target's answer (SHAVING.md): the mesh and wheel figures, and side
  // by side the pinion's diagonal modification on its own flank and the cutter target it needs.
  function renderShaving(answer) {
    const a = answer || {};
    const section = html("section", { class: "shaving-view" });
    const radii = a.wheel_radius_min_mm || {};
    const rows = [
      ["crossed-axes angle", fmt(a.crossed_axes_angle_deg, 3) + " deg"],
      ["centre distance", fmt(a.centre_distance_mm, 4) + " mm"],
      ["contact-line length", fmt(a.contact_line_length_mm, 3) + " mm"],
      ["minimum wheel radius", "fixed " + fmt(radii.fixed, 2) + " mm, traversing " + fmt(radii.traversing, 2) + " mm"],
      ["points generated", String(a.generated) + " of " + String(a.points)],
    ];
    const notGenerated = (a.outside_work_flank || []).length + (a.not_converged || []).length;
    if (notGenerated) rows.push(["not generated", (a.outside_work_flank || []).length + " outside the work flank, " + (a.not_converged || []).length + " not converged (no value)"]);
    section.appendChild(
      html(
        "table",
        { class: "summary shaving-summary" },
        rows.map((r) => html("tr", {}, [html("th", { text: r[0] }), html("td", { text: r[1] })]))
      )
    );
    section.appendChild(html("h3", { text: "Pinion modification and the cutter target (\u00b5m, + = material left on)" }));
    const maps = html("div", { class: "chart-row maps shaving-maps" });
    maps.appendChild(heatmap(a.work_modification_um || [], { title: "pinion modification", subtitle: "diagonal relief on the work gear's flank (negative = relief)" }));
    maps.appendChild(heatmap(a.stock_target_um || [], { title: "cutter target", subtitle: "stock-referenced: the grinding correction's target" }));
    section.appendChild(maps);
    return section;
  }

  global.GearloopPlots = { isBevel, isSplitTrajectory, renderSplitTrajectory, heatmap, lineChart, axisCurves, axisMotionTable, isoTable, convergence, renderJob, renderShaving, measuredGrid, targetGrid, nextPartRows, html, svg, fmt, colour };
})(window);
