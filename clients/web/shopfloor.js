// clients/web/shopfloor.js: the dashboard's machine-side views, drawn from the API's answers.
//
//   GearloopShopFloor.parseSettingsCsv(text)      // GET .../settings?format=csv -> {axes, names}
//   GearloopShopFloor.axisMotionCurves(listing)   // commanded vs corrected motion, one box per axis
//   GearloopShopFloor.topography3d(job)           // measured, target, predicted flank as 3-D canvases
//
// The settings listing (docs/settings-listing.md) gives each polynomial axis's corrected position
// (mm or rad) and its change (um or urad) at roll angles over the roll range; the commanded
// position is the corrected one less the change. Grids follow the API: row 0 at the root, column
// 0 at x < 0, um, positive = material left on, null = no value.
"use strict";

(function (global) {
  const P = global.GearloopPlots;
  const isNum = (v) => typeof v === "number" && Number.isFinite(v);
  // The change column's unit per axis unit, and what one change unit is in the axis unit.
  const CHANGE_SCALE = { um: 1e-3, urad: 1e-6 };
  // Below this span the positions are drawn as an offset in um / urad, above it in mm / rad.
  const OFFSET_SPAN = { mm: 0.1, rad: 1e-3 };

  // The motion records of a settings listing in CSV; an Error names the line that is not one.
  function parseSettingsCsv(text) {
    const lines = String(text || "").split(/\r?\n/).filter((l) => l.trim() !== "");
    const header = "record,block,power,roll_rad,unit,absolute,change,change_unit";
    if (!lines.length || lines[0].trim() !== header) throw new Error("line 1: not a settings listing (header " + header + ")");
    const axes = {};
    const names = [];
    for (let i = 1; i < lines.length; ++i) {
      const cells = lines[i].split(",");
      if (cells.length !== 8) throw new Error("line " + (i + 1) + ": " + cells.length + " fields, expected 8");
      if (cells[0] !== "motion") continue;
      const [roll, absolute, change] = [cells[3], cells[5], cells[6]].map(Number);
      if (![roll, absolute, change].every(isNum)) throw new Error("line " + (i + 1) + ": a motion record without numbers");
      const name = cells[1];
      if (!axes[name]) {
        axes[name] = { unit: cells[4], change_unit: cells[7], roll_rad: [], corrected: [], change: [], commanded: [] };
        names.push(name);
      }
      const a = axes[name];
      a.roll_rad.push(roll);
      a.corrected.push(absolute);
      a.change.push(change);
      a.commanded.push(absolute - change * (CHANGE_SCALE[a.change_unit] || 0));
    }
    return { axes, names };
  }

  // One axis: its commanded and corrected position over the roll (in mm / rad, or as an offset
  // in um / urad from the commanded position at mid-roll when the axis barely moves), and below
  // it the change between them in the listing's change unit.
  function axisBox(name, a, rollLabel) {
    const degs = a.roll_rad.map((r) => (r * 180) / Math.PI);
    const all = a.commanded.concat(a.corrected);
    const span = Math.max(...all) - Math.min(...all);
    const offset = span < (OFFSET_SPAN[a.unit] || 0);
    const ref = a.commanded[Math.floor(a.commanded.length / 2)];
    const scale = offset ? 1 / (CHANGE_SCALE[a.change_unit] || 1) : 1;
    const shown = (v) => (offset ? (v - ref) * scale : v);
    const small = a.change_unit === "urad" ? "\u00b5rad" : "\u00b5m";
    const yLabel = offset ? name + " \u2212 " + ref.toFixed(a.unit === "mm" ? 6 : 9) + " " + a.unit + " [" + small + "]" : name + " [" + a.unit + "]";
    const position = P.lineChart(
      [
        { name: "commanded", x: degs, y: a.commanded.map(shown), colour: "#5b6570" },
        { name: "corrected", x: degs, y: a.corrected.map(shown), colour: "#d62728", dashed: true },
      ],
      { title: name + ": commanded vs corrected", xLabel: rollLabel, yLabel, width: 330, height: 220, yZero: false }
    );
    position.classList.add("axis-position");
    const maxAbs = Math.max(...a.change.map(Math.abs));
    const change = P.lineChart([{ name: "corrected \u2212 commanded", x: degs, y: a.change, colour: "#1f5fa8" }], {
      title: "change, max |\u0394| " + P.fmt(maxAbs, 2) + " " + small,
      xLabel: rollLabel,
      yLabel: "\u0394" + name + " [" + small + "]",
      width: 330,
      height: 170,
    });
    change.classList.add("axis-change");
    return P.html("div", { class: "axis-motion-curve", "data-axis": name, "data-unit": offset ? small : a.unit }, [position, change]);
  }

  // Every axis of the listing, in its order (X, Y, Z, A, B, C for the grinder).
  function axisMotionCurves(listing, bevel) {
    const rollLabel = bevel ? "cradle roll t [deg]" : "roll angle \u03c6\u2081 [deg]";
    const box = P.html("div", { class: "chart-row axis-motion-curves", "data-axes": listing.names.length });
    for (const name of listing.names) box.appendChild(axisBox(name, listing.axes[name], rollLabel));
    return box;
  }

  // The grid's axes: for a ground gear the roll length L [mm] of each row (MODEL.md section 4:
  // L_form + p (L_a - L_form), p over the grid's profile range) and x [mm] of each column
  // (l b, l over the lead range); for any other job the row and column numbers.
  function gridAxes(job, rows, columns) {
    const req = job.request || {};
    const gear = req.gear || {};
    const grid = req.grid || {};
    const even = (lo, hi, n) => Array.from({ length: n }, (_, i) => lo + ((hi - lo) * i) / Math.max(1, n - 1));
    const numbered = { rowValues: even(1, rows, rows), colValues: even(1, columns, columns), rowTitle: "profile point (root \u2192 tip)", colTitle: "lead point", digits: 0 };
    if (P.isBevel(job)) return Object.assign(numbered, { rowTitle: "profile point (root \u2192 face)", colTitle: "lengthwise point (toe \u2192 heel)" });
    const g = ["teeth", "normal_module_mm", "normal_pressure_angle_deg", "face_width_mm", "tip_radius_mm", "root_radius_mm"].every((k) => isNum(gear[k]));
    if (!g) return numbered;
    const beta = ((gear.helix_angle_deg || 0) * Math.PI) / 180;
    const rj = (gear.teeth * gear.normal_module_mm) / (2 * Math.cos(beta));
    const at = Math.atan(Math.tan((gear.normal_pressure_angle_deg * Math.PI) / 180) / Math.cos(beta));
    const rb = rj * Math.cos(at);
    const lForm = Math.max(0, rj * Math.sin(at) - (rj - gear.root_radius_mm) / Math.sin(at));
    const lTip = Math.sqrt(Math.max(0, gear.tip_radius_mm * gear.tip_radius_mm - rb * rb));
    const pr = grid.profile_range || [0.2, 0.9];
    const lr = grid.lead_range || [-0.4, 0.4];
    return {
      rowValues: even(pr[0], pr[1], rows).map((p) => lForm + p * (lTip - lForm)),
      colValues: even(lr[0], lr[1], columns).map((l) => l * gear.face_width_mm),
      rowTitle: "roll length L [mm] (root \u2192 tip)",
      colTitle: "lead x [mm]",
      digits: 1,
    };
  }

  // The three grids of a job: measured, target and the predicted part (target + predicted
  // residual, or measured + predicted change for a job without a target grid).
  function jobSurfaces(job) {
    const r = job.result || {};
    const measured = P.measuredGrid(job);
    const target = P.targetGrid(job);
    const residual = r.predicted_residual_um;
    const add = (a, b) => (a && b ? a.map((row, i) => row.map((v, j) => (isNum(v) && isNum((b[i] || [])[j]) ? v + b[i][j] : null))) : null);
    const predicted = target ? add(target, residual) : add(measured, r.predicted_change_um);
    return [
      ["measured", "measured", measured, "as the measuring machine reported it"],
      ["target", "target", target, "the designed modification"],
      ["predicted", "predicted part", predicted, target ? "target + predicted residual" : "measured + predicted change"],
    ].filter((s) => s[2] && s[2].length >= 2 && s[2][0].length >= 2);
  }

  // An oblique view of one grid: lead to the right, profile receding up-right, the deviation
  // up (one px-per-um scale k shared by the three views); each grid cell a quad in the colour of
  // its mean, drawn back to front, over the zero plane. Returns the quads drawn.
  function drawSurface(ctx, grid, axes, geom) {
    const rows = grid.length;
    const cols = grid[0].length;
    const at = (r, c, d) => [
      geom.ox + (c / (cols - 1)) * geom.lead + (r / (rows - 1)) * geom.dx,
      geom.oy + (r / (rows - 1)) * geom.dy - d * geom.k,
    ];
    ctx.strokeStyle = "#c3c9d0";
    ctx.lineWidth = 1;
    for (let r = 0; r < rows; ++r) line(ctx, [at(r, 0, 0), at(r, cols - 1, 0)]);
    for (let c = 0; c < cols; ++c) line(ctx, [at(0, c, 0), at(rows - 1, c, 0)]);
    let quads = 0;
    for (let r = rows - 2; r >= 0; --r) {
      for (let c = 0; c < cols - 1; ++c) {
        const v = [grid[r][c], grid[r][c + 1], grid[r + 1][c + 1], grid[r + 1][c]];
        if (!v.every(isNum)) continue;
        const corners = [at(r, c, v[0]), at(r, c + 1, v[1]), at(r + 1, c + 1, v[2]), at(r + 1, c, v[3])];
        ctx.beginPath();
        corners.forEach((p, i) => (i ? ctx.lineTo(p[0], p[1]) : ctx.moveTo(p[0], p[1])));
        ctx.closePath();
        ctx.fillStyle = P.colour((v[0] + v[1] + v[2] + v[3]) / 4, geom.maxAbs);
        ctx.fill();
        ctx.strokeStyle = "#333";
        ctx.stroke();
        quads += 1;
      }
    }
    labelAxes(ctx, axes, at, rows, cols, geom);
    return quads;
  }

  function line(ctx, pts) {
    ctx.beginPath();
    ctx.moveTo(pts[0][0], pts[0][1]);
    for (const p of pts.slice(1)) ctx.lineTo(p[0], p[1]);
    ctx.stroke();
  }

  // Lead ticks under the front edge, profile ticks along the right edge, the deviation scale
  // standing at the front-left corner; every axis with its unit.
  function labelAxes(ctx, axes, at, rows, cols, geom) {
    ctx.fillStyle = "#333";
    ctx.strokeStyle = "#444";
    ctx.font = "11px system-ui, sans-serif";
    const mid = (n) => [0, Math.floor((n - 1) / 2), n - 1];
    // The lead and profile axes on the box's floor, below the lowest the surfaces reach.
    const drop = geom.maxAbs + 8 / geom.k;
    const onFloor = (r, c) => at(r, c, -drop);
    ctx.textAlign = "center";
    line(ctx, [onFloor(0, 0), onFloor(0, cols - 1), onFloor(rows - 1, cols - 1)]);
    for (const c of mid(cols)) {
      const p = onFloor(0, c);
      line(ctx, [p, [p[0], p[1] + 5]]);
      ctx.fillText(axes.colValues[c].toFixed(axes.digits), p[0], p[1] + 17);
    }
    ctx.font = "12px system-ui, sans-serif";
    ctx.fillText(axes.colTitle, onFloor(0, (cols - 1) / 2)[0], onFloor(0, 0)[1] + 33);
    ctx.font = "11px system-ui, sans-serif";
    ctx.textAlign = "left";
    for (const r of mid(rows)) {
      const p = onFloor(r, cols - 1);
      line(ctx, [p, [p[0] + 5, p[1]]]);
      ctx.fillText(axes.rowValues[r].toFixed(axes.digits), p[0] + 8, p[1] + 4);
    }
    // The profile title along the floor's right edge, outside it.
    const norm = Math.hypot(geom.dx, geom.dy);
    const edge = onFloor((rows - 1) / 2, cols - 1);
    ctx.save();
    ctx.font = "12px system-ui, sans-serif";
    ctx.textAlign = "center";
    ctx.translate(edge[0] + (-geom.dy / norm) * 34, edge[1] + (geom.dx / norm) * 34);
    ctx.rotate(Math.atan2(geom.dy, geom.dx));
    ctx.fillText(axes.rowTitle, 0, 0);
    ctx.restore();
    const step = niceStep(geom.maxAbs);
    // As many decimals as the step needs (2.5 -> 1, 0.25 -> 2).
    let digits = 0;
    while (digits < 6 && Math.abs(step * Math.pow(10, digits) - Math.round(step * Math.pow(10, digits))) > 1e-6) digits += 1;
    const x = geom.ox - 14;
    line(ctx, [[x, geom.oy - geom.maxAbs * geom.k], [x, geom.oy + geom.maxAbs * geom.k]]);
    ctx.textAlign = "right";
    for (let t = -Math.floor(geom.maxAbs / step) * step; t <= geom.maxAbs + 1e-9; t += step) {
      const y = geom.oy - t * geom.k;
      line(ctx, [[x - 4, y], [x, y]]);
      ctx.fillText((Math.abs(t) < step * 1e-6 ? 0 : t).toFixed(digits), x - 6, y + 4);
    }
    ctx.textAlign = "left";
    ctx.fillText("\u00b5m", x - 22, geom.oy - geom.maxAbs * geom.k - 8);
  }

  function niceStep(maxAbs) {
    const raw = maxAbs / 2;
    const mag = Math.pow(10, Math.floor(Math.log10(raw)));
    return [1, 2, 2.5, 5, 10].map((m) => m * mag).find((s) => s >= raw) || 10 * mag;
  }

  // One canvas per grid, side by side, on one vertical scale; canvas.dataset.quads says how many
  // cells were drawn (a cell with a missing corner is left out).
  function topography3d(job) {
    const surfaces = jobSurfaces(job);
    const box = P.html("div", { class: "chart-row topo3d-row" });
    let maxAbs = 0;
    for (const s of surfaces) for (const row of s[2]) for (const v of row) if (isNum(v)) maxAbs = Math.max(maxAbs, Math.abs(v));
    maxAbs = maxAbs > 0 ? maxAbs : 1;
    const width = 322;
    const height = 300;
    const ratio = global.devicePixelRatio || 1;
    for (const [key, title, grid, subtitle] of surfaces) {
      const canvas = P.html("canvas", { class: "topo3d", "data-surface": key, width: width * ratio, height: height * ratio, style: "width:" + width + "px;height:" + height + "px", role: "img", "aria-label": title + ", 3-D view in micrometres" });
      const ctx = canvas.getContext("2d");
      ctx.scale(ratio, ratio);
      ctx.fillStyle = "#fff";
      ctx.fillRect(0, 0, width, height);
      ctx.fillStyle = "#1b1f24";
      ctx.font = "600 14px system-ui, sans-serif";
      ctx.fillText(title, 12, 20);
      ctx.font = "11px system-ui, sans-serif";
      ctx.fillStyle = "#5b6570";
      ctx.fillText(subtitle, 12, 36);
      const axes = gridAxes(job, grid.length, grid[0].length);
      const geom = { ox: 48, oy: 172, lead: 140, dx: 66, dy: -60, maxAbs, k: 50 / maxAbs };
      canvas.setAttribute("data-quads", String(drawSurface(ctx, grid, axes, geom)));
      canvas.setAttribute("data-rows", String(grid.length));
      canvas.setAttribute("data-columns", String(grid[0].length));
      box.appendChild(canvas);
    }
    return box;
  }

  global.GearloopShopFloor = { parseSettingsCsv, axisMotionCurves, topography3d, jobSurfaces };
})(window);
