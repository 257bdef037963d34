// clients/web/test/dashboard.test.js: the dashboard in Debian's headless Chromium against a real
// gearloop-server holding real jobs. Checks that the page loads, lists the jobs, shows a job's
// three topographies with readable numbers, the axis-correction and convergence plots, the
// printable report and a simulated closed loop, with no console error; writes screenshots.
//
//   node dashboard.test.js /path/to/gearloop-server /path/to/output-dir [/path/to/gearloop]
// With the CLI given, the self-contained report it writes is opened from a file:// address too.
"use strict";

const { chromium } = require("playwright-core");
const { spawn, execFileSync } = require("child_process");
const fs = require("fs");
const net = require("net");
const os = require("os");
const path = require("path");

const REPO = path.resolve(__dirname, "..", "..", "..");
const EXAMPLES = path.join(REPO, "clients", "examples");
const serverBin = process.argv[2];
const outDir = path.resolve(process.argv[3] || path.join(os.tmpdir(), "gearloop-web-test"));
const cliBin = process.argv[4] || "";

let passed = 0;
let failed = 0;
function check(name, ok, detail) {
  if (ok) {
    passed += 1;
    console.log("ok   " + name);
  } else {
    failed += 1;
    console.log("FAIL " + name + (detail ? ": " + detail : ""));
  }
}

function freePort() {
  return new Promise((resolve, reject) => {
    const s = net.createServer();
    s.once("error", reject);
    s.listen(0, "127.0.0.1", () => {
      const port = s.address().port;
      s.close(() => resolve(port));
    });
  });
}

const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

async function api(base, method, p, body, token) {
  const headers = body ? { "Content-Type": "application/json" } : {};
  if (token) headers.Authorization = "Bearer " + token;
  const res = await fetch(base + p, {
    method,
    headers,
    body: body ? JSON.stringify(body) : undefined,
  });
  const data = await res.json();
  if (!res.ok) throw new Error(method + " " + p + " -> " + res.status + " " + JSON.stringify(data));
  return data;
}

async function startServer(tmp, extraArgs) {
  const port = await freePort();
  const log = fs.openSync(path.join(outDir, "server.log"), "a");
  const args = ["--host", "127.0.0.1", "--port", String(port), "--db", path.join(tmp, "jobs.sqlite")].concat(extraArgs || []);
  const child = spawn(serverBin, args, {
    stdio: ["ignore", log, log],
  });
  const base = "http://127.0.0.1:" + port;
  for (let i = 0; i < 300; ++i) {
    if (child.exitCode !== null) throw new Error("gearloop-server exited with " + child.exitCode);
    try {
      const r = await fetch(base + "/healthz");
      if (r.ok) return { child, base };
    } catch (e) {
      /* not up yet */
    }
    await sleep(100);
  }
  child.kill("SIGTERM");
  throw new Error("gearloop-server did not answer /healthz");
}

async function main() {
  if (!serverBin || !fs.existsSync(serverBin)) throw new Error("usage: node dashboard.test.js GEARLOOP_SERVER_BIN [OUT_DIR]");
  fs.mkdirSync(outDir, { recursive: true });
  const tmp = fs.mkdtempSync(path.join(os.tmpdir(), "gearloop-web-"));
  const { child, base } = await startServer(tmp);
  let context = null;
  try {
    // Real jobs: a closed loop stored as a chain of settings revisions, then one correction of
    // a measured part (the example files of clients/examples).
    const scenario = JSON.parse(fs.readFileSync(path.join(EXAMPLES, "scenario.json"), "utf8"));
    const loop = await api(base, "POST", "/api/v1/simulations/closed-loop", Object.assign({}, scenario, { corrections: 3, store: true }));
    const chainIds = loop.iterations.map((it) => it.job_id).filter((id) => typeof id === "number");
    const request = JSON.parse(fs.readFileSync(path.join(EXAMPLES, "request.json"), "utf8"));
    const measurement = JSON.parse(fs.readFileSync(path.join(EXAMPLES, "measurement.json"), "utf8"));
    request.measurement = { deviations_um: measurement.deviations_um };
    const job = await api(base, "POST", "/api/v1/corrections", request);
    check("server stored the jobs", job.id > 0 && chainIds.length >= 2, "chain " + JSON.stringify(chainIds));

    const userDataDir = fs.mkdtempSync(path.join(os.tmpdir(), "gearloop-chromium-"));
    context = await chromium.launchPersistentContext(userDataDir, {
      executablePath: "/usr/bin/chromium",
      headless: true,
      args: [
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-background-networking",
        "--no-first-run",
        "--disable-component-update",
        "--disable-sync",
        "--disable-quic",
      ],
      viewport: { width: 1500, height: 1000 },
    });
    const page = context.pages()[0] || (await context.newPage());
    const consoleErrors = [];
    page.on("console", (msg) => {
      if (msg.type() === "error") consoleErrors.push(msg.text());
    });
    page.on("pageerror", (err) => consoleErrors.push("page error: " + err.message));
    page.on("requestfailed", (req) => consoleErrors.push("request failed: " + req.url()));

    // 1. The dashboard opens on the newest job.
    await page.goto(base + "/", { waitUntil: "load" });
    await page.waitForSelector("body[data-job-shown='" + job.id + "']", { timeout: 30000 });
    const rows = await page.$$eval("#jobs tbody tr", (trs) => trs.map((tr) => tr.getAttribute("data-job-id")));
    check("history lists every job", rows.length === chainIds.length + 1 && rows[0] === String(job.id), JSON.stringify(rows));
    const heads = await page.$$eval("#jobs thead th", (ths) => ths.map((th) => th.textContent));
    check("history columns", heads.length === 5 && heads[0] === "id" && heads[4] === "created (UTC)", JSON.stringify(heads));
    check("health shows the server version", /server ok/.test(await page.textContent("#health")));

    const maps = await page.$$eval("svg.heatmap", (svgs) =>
      svgs.map((s) => ({ title: s.querySelector(".plot-title").textContent, cells: s.querySelectorAll("rect.cell").length, values: Array.from(s.querySelectorAll(".cell-value")).map((t) => t.textContent) }))
    );
    check("three topographies", maps.map((m) => m.title).join(",") === "measured,target,predicted residual", JSON.stringify(maps.map((m) => m.title)));
    check("45 cells in each", maps.every((m) => m.cells === 45 && m.values.length === 45));
    // The tip row is drawn first (top); the measured tip corner at x > 0 is missing.
    const tip = measurement.deviations_um[4];
    const topRow = maps[0].values.slice(0, 9);
    check("measured numbers readable, tip at top", topRow[0] === tip[0].toFixed(2) && topRow[8] === "\u2013", JSON.stringify(topRow));
    const root = measurement.deviations_um[0];
    check("root row at the bottom", maps[0].values.slice(36, 45).join() === root.map((v) => v.toFixed(2)).join(), JSON.stringify(maps[0].values.slice(36)));
    const residual = job.result.predicted_residual_um;
    check("predicted residual numbers", Number(maps[2].values[36]) === Number(residual[0][0].toFixed(2)), maps[2].values[36] + " vs " + residual[0][0]);
    const curves = await page.$$eval("svg.chart polyline.series", (ls) => ls.map((l) => l.getAttribute("data-name")));
    check("axis corrections drawn as curves", ["X", "Y", "Z", "A", "B", "C"].every((a) => curves.includes(a)), JSON.stringify(curves));
    check("convergence plot present", (await page.$$("svg.convergence")).length === 1);
    const summary = await page.$$eval("table.summary tr", (trs) => trs.map((tr) => [tr.querySelector("th").textContent, tr.querySelector("td").textContent]));
    const linearised = summary.find((row) => row[0] === "linearised at");
    check("summary says where the correction was linearised", linearised !== undefined && /^estimated machine state \(size /.test(linearised[1]), JSON.stringify(linearised));
    const exactSearch = summary.find((row) => row[0] === "exact-model search");
    check("summary says what the exact-model search did", exactSearch !== undefined && exactSearch[1] !== "" && exactSearch[1] === job.result.exact_search.outcome, JSON.stringify(exactSearch));
    const motionRows = await page.$$eval("table.axis-motion tr[data-axis]", (trs) =>
      trs.map((tr) => ({ axis: tr.getAttribute("data-axis"), cells: Array.from(tr.querySelectorAll("td")).map((td) => td.textContent) }))
    );
    const xMotion = job.result.axis_motion.axes.X;
    check("axis motion table, one row per axis", motionRows.map((r) => r.axis).join() === "X,Y,Z,A,B,C" && motionRows.every((r) => r.cells.length === 11), JSON.stringify(motionRows.map((r) => r.axis)));
    check("axis motion in um", motionRows.length > 0 && Number(motionRows[0].cells[0]) === Number(xMotion.change_um[0].toFixed(2)) && Number(motionRows[0].cells[10]) === Number(xMotion.max_abs_um.toFixed(2)), JSON.stringify(motionRows[0]));
    // The ISO 1328-1 figures and classes beside the maps: measured, against the target, predicted.
    const isoRows = await page.$$eval("table.iso1328 tr[data-figure]", (trs) =>
      trs.map((tr) => ({ figure: tr.getAttribute("data-figure"), cells: Array.from(tr.querySelectorAll("td")).map((td) => td.textContent) }))
    );
    const isoClass = (v) => (typeof v === "number" ? String(v) : ">11");
    const fa = isoRows.find((r) => r.figure === "Fa_max_abs");
    const iso = job.result.iso1328;
    check(
      "ISO 1328-1 figures and classes beside the maps",
      fa !== undefined && Number(fa.cells[0]) === Number(iso.measured.figures.Fa_max_abs.toFixed(2)) && fa.cells[1] === isoClass(iso.measured.classes.Fa) && fa.cells[5] === isoClass(iso.predicted.classes.Fa),
      JSON.stringify(fa)
    );
    const csv = await page.evaluate(async (name) => {
      const link = document.querySelector("a[download='" + name + "']");
      return link ? (await fetch(link.href)).text() : "";
    }, "job" + job.id + "-measured.csv");
    const csvLines = csv.trim().split("\n");
    check("measured grid downloads as CSV", csvLines.length === 6 && csvLines[1] === root.join(",") && csvLines[5].endsWith(","), JSON.stringify(csvLines.slice(0, 2)));
    await page.screenshot({ path: path.join(outDir, "dashboard.png"), fullPage: true });

    // 1b. The axis motion of the job, commanded vs corrected, from its settings listing, and the
    //     flank's three topographies as 3-D surfaces.
    await page.waitForSelector("body[data-motion-shown='" + job.id + "']", { timeout: 30000 });
    const motionBoxes = await page.$$eval(".axis-motion-curve", (boxes) =>
      boxes.map((b) => ({
        axis: b.getAttribute("data-axis"),
        unit: b.getAttribute("data-unit"),
        series: Array.from(b.querySelectorAll("polyline.series")).map((l) => l.getAttribute("data-name") + ":" + l.getAttribute("points").split(" ").length),
        title: b.querySelector("svg.axis-change .plot-title").textContent,
      }))
    );
    check(
      "axis motion: one box per axis, commanded and corrected at 41 roll angles",
      motionBoxes.map((b) => b.axis).join() === "X,Y,Z,A,B,C" && motionBoxes.every((b) => b.series.join() === "commanded:41,corrected:41,corrected \u2212 commanded:41"),
      JSON.stringify(motionBoxes.map((b) => [b.axis, b.series]))
    );
    check("axis motion: units on the axes", motionBoxes.every((b) => (["X", "Y", "Z"].includes(b.axis) ? ["mm", "\u00b5m"] : ["rad", "\u00b5rad"]).includes(b.unit)), JSON.stringify(motionBoxes.map((b) => b.axis + " " + b.unit)));
    // The largest change the page states is the listing's own (CSV of the same samples).
    const listing = (await (await fetch(base + "/api/v1/corrections/" + job.id + "/settings?format=csv&samples=41")).text()).trim().split("\n");
    const zChange = listing.filter((l) => l.startsWith("motion,Z,")).map((l) => Math.abs(Number(l.split(",")[6])));
    const zBox = motionBoxes.find((b) => b.axis === "Z");
    check("axis motion: the change of Z as listed", zChange.length === 41 && zBox !== undefined && zBox.title === "change, max |\u0394| " + Math.max(...zChange).toFixed(2) + " \u00b5m", zBox && zBox.title);
    const surfaces = await page.$$eval("canvas.topo3d", (cs) =>
      cs.map((c) => {
        const data = c.getContext("2d").getImageData(0, 0, c.width, c.height).data;
        let coloured = 0;
        for (let i = 0; i < data.length; i += 4) if (Math.abs(data[i] - data[i + 2]) > 40) coloured += 1;
        return { surface: c.getAttribute("data-surface"), quads: Number(c.getAttribute("data-quads")), coloured };
      })
    );
    // 4 x 8 cells of the 5 x 9 grid; the measured tip corner at x > 0 is missing, so is the cell
    // touching it in the measured and the predicted part.
    check("3-D view: measured, target, predicted part", surfaces.map((s) => s.surface).join() === "measured,target,predicted", JSON.stringify(surfaces));
    check("3-D view: cells drawn, none with a missing corner", surfaces.map((s) => s.quads).join() === "31,32,31", JSON.stringify(surfaces.map((s) => s.quads)));
    check("3-D view: surfaces coloured by deviation", surfaces.every((s) => s.coloured > 500), JSON.stringify(surfaces.map((s) => s.coloured)));
    await (await page.$("section.flank-3d")).screenshot({ path: path.join(outDir, "dashboard-3d.png") });
    await (await page.$("section.axis-motion-section")).screenshot({ path: path.join(outDir, "dashboard-axis-motion.png") });

    // 2. A job of the closed-loop chain: the convergence plot has one point per correction.
    const last = chainIds[chainIds.length - 1];
    await page.click("#jobs tbody tr[data-job-id='" + last + "']");
    await page.waitForSelector("body[data-job-shown='" + last + "']", { timeout: 30000 });
    const points = await page.$$eval("svg.convergence circle", (cs) => cs.length);
    check("convergence over the lineage", points >= chainIds.length, "markers " + points);
    await page.screenshot({ path: path.join(outDir, "dashboard-closed-loop.png"), fullPage: true });

    // 3. The next part by hand: a bad file is refused with its line and column, a good one
    //    becomes a new job ground with this job's settings.
    const bad = path.join(outDir, "bad-part.csv");
    fs.writeFileSync(bad, "1,2,3,4,5,6,7,8,9\n1,2,3,4,5,6,7,8,9\n1,2,x,4,5,6,7,8,9\n");
    await page.setInputFiles("#next-part-file", bad);
    await page.waitForSelector("#next-part-status.error", { timeout: 30000 });
    check("bad measurement file named", /line 3, column 3/.test(await page.textContent("#next-part-status")), await page.textContent("#next-part-status"));
    await page.setInputFiles("#next-part-file", path.join(EXAMPLES, "measurement.csv"));
    await page.waitForFunction((old) => {
      const shown = document.body.getAttribute("data-job-shown");
      return shown && Number(shown) > old;
    }, Math.max(job.id, ...chainIds), { timeout: 60000 });
    const nextId = Number(await page.getAttribute("body", "data-job-shown"));
    const next = await api(base, "GET", "/api/v1/corrections/" + nextId);
    check("next part stored and linked", next.settings_source_job_id === last && JSON.stringify(next.request.settings) === JSON.stringify((await api(base, "GET", "/api/v1/corrections/" + last)).result.settings), JSON.stringify({ id: nextId, source: next.settings_source_job_id }));
    const nextPoints = await page.$$eval("svg.convergence circle", (cs) => cs.length);
    check("convergence grows by the next part", nextPoints > points, nextPoints + " vs " + points);
    await page.screenshot({ path: path.join(outDir, "dashboard-next-part.png"), fullPage: true });

    // 3b. A replay of the shown job with another solver opens the new, linked job.
    await page.selectOption("#replay-solver", "lsq-plain");
    await page.click("#replay");
    await page.waitForFunction((old) => Number(document.body.getAttribute("data-job-shown")) > old, nextId, { timeout: 60000 });
    const replayId = Number(await page.getAttribute("body", "data-job-shown"));
    const replayed = await api(base, "GET", "/api/v1/corrections/" + replayId);
    check("replay from the page", replayed.kind === "replay" && replayed.parent_job_id === nextId && replayed.result.solver === "lsq-plain", JSON.stringify({ kind: replayed.kind, parent: replayed.parent_job_id }));

    // 3c. A new correction from job N's setup with another measured part's grid: the answer is
    //     shown beside the panel, the job joins the history, the page stays on job N.
    await page.evaluate((n) => {
      window.location.hash = "job=" + n;
    }, job.id);
    await page.waitForSelector("body[data-job-shown='" + job.id + "']", { timeout: 30000 });
    await page.setInputFiles("#new-correction-file", path.join(EXAMPLES, "measurement.csv"));
    await page.waitForSelector("body[data-new-correction]", { timeout: 60000 });
    const againId = Number(await page.getAttribute("body", "data-new-correction"));
    const again = await api(base, "GET", "/api/v1/corrections/" + againId);
    const stored = await api(base, "GET", "/api/v1/corrections/" + job.id);
    const answerRows = Object.fromEntries(await page.$$eval("#new-correction-result table.answer tr", (trs) => trs.map((tr) => [tr.querySelector("th").textContent, tr.querySelector("td").textContent])));
    check(
      "new correction from job N's setup",
      again.kind === "correction" && !again.settings_source_job_id && JSON.stringify(again.request.target) === JSON.stringify(stored.request.target) && JSON.stringify(again.request.gear) === JSON.stringify(stored.request.gear) && again.trace.file_name === "measurement.csv" && JSON.stringify(again.result.measured_um[0]) === JSON.stringify(root),
      JSON.stringify({ id: againId, kind: again.kind, trace: again.trace })
    );
    check(
      "new correction: its answer shown",
      answerRows["status"] === again.status + (again.result.message ? " \u2014 " + again.result.message : "") && answerRows["predicted residual rms / max"] === again.result.residual_rms_um.toFixed(3) + " / " + again.result.residual_max_um.toFixed(3) + " \u00b5m",
      JSON.stringify(answerRows)
    );
    const band = again.result.prediction_band;
    check(
      "new correction: how sure its prediction is",
      answerRows["next part true rms (2\u03c3 band)"] ===
        band.expected_true_rms_um.toFixed(3) + " \u00b5m (" + band.true_rms_2sigma_um[0].toFixed(3) + " \u2013 " + band.true_rms_2sigma_um[1].toFixed(3) + " \u00b5m; noise " + band.noise_sigma_um.toFixed(3) + " \u00b5m " + (band.noise_stated ? "stated" : "estimated") +
          (typeof band.stated_noise_um === "number" ? " from the measurement's scatter; " + band.stated_noise_um.toFixed(3) + " \u00b5m stated is contradicted" : "") +
          (band.misfit_read_as_flank === true ? " from a misfit, more than a probe scatters: the expected value counts all but " + band.noise_read_as_probe_um.toFixed(3) + " \u00b5m of it as flank the next part keeps" : "") + ")",
      JSON.stringify(answerRows)
    );
    const parabola = again.result.safe_step.wheel_parabola;
    check(
      "new correction: the wheel parabola its safe step hedged",
      parabola &&
        answerRows["wheel parabola (rms of flank)"] ===
          (parabola.source === "measurement"
            ? parabola.estimate_flank_um.toFixed(3) + " \u00b1 " + parabola.sd_flank_um.toFixed(3) + " \u00b5m as the measurement shows it"
            : parabola.hedged_flank_um.toFixed(3) + " \u00b5m assumed (noise not known)"),
      JSON.stringify({ parabola, answerRows })
    );
    check("new correction in the history", (await page.$$("#jobs tbody tr[data-job-id='" + againId + "']")).length === 1 && (await page.getAttribute("body", "data-job-shown")) === String(job.id));
    await page.screenshot({ path: path.join(outDir, "dashboard-new-correction.png"), fullPage: true });

    // 3d. The target changed and replayed: lead crowning 4 -> 8 um and a profile crowning of
    //     3 um added; what the machine can make of it first, then the replay.
    await page.click("#target-editor summary");
    const modRows = await page.$$("#target-mods .mod-row");
    check("target editor holds the stored modification", modRows.length === 1 && (await page.inputValue("#target-mods .mod-row .mod-amount")) === "4", String(modRows.length));
    await page.fill("#target-mods .mod-row .mod-amount", "8");
    await page.click("#target-add");
    await page.selectOption("#target-mods .mod-row:nth-child(2) .mod-kind", "profile_crowning");
    await page.fill("#target-mods .mod-row:nth-child(2) .mod-amount", "3");
    const newTarget = { modifications: [{ kind: "lead_crowning", amount_um: 8 }, { kind: "profile_crowning", amount_um: 3 }] };
    await page.click("#reach-target");
    await page.waitForSelector("#reach-result table.reach, #target-status.error", { timeout: 60000 });
    const reachBody = { target: newTarget };
    for (const k of ["gear", "wheel", "machine", "grid", "flank", "settings", "options"]) if (stored.request[k] !== undefined) reachBody[k] = stored.request[k];
    const reachAnswer = await api(base, "POST", "/api/v1/targets/reach", reachBody);
    const reachRows = await page.$$eval("#reach-result table.reach tr", (trs) => trs.slice(1).map((tr) => Array.from(tr.children).map((c) => c.textContent)));
    check(
      "reach of the changed target",
      reachRows.length >= 3 && reachRows[0][0] === "lead crowning 8.0" && reachRows[1][0] === "profile crowning 3.0" && reachRows[2][3] === (100 * reachAnswer.combined.reachable_share).toFixed(1) + " %",
      JSON.stringify(reachRows)
    );
    await page.click("#replay-target");
    await page.waitForFunction((old) => Number(document.body.getAttribute("data-job-shown")) > old, againId, { timeout: 60000 });
    const retargetId = Number(await page.getAttribute("body", "data-job-shown"));
    const retarget = await api(base, "GET", "/api/v1/corrections/" + retargetId);
    // At the grid's root row, x < 0 end: -8 (lead, eta = -1) - 3 (profile, xi = 0). The server
    // stores the request with its keys sorted: the modifications are compared field by field.
    check(
      "replay with the changed target",
      retarget.kind === "replay" && retarget.parent_job_id === job.id && retarget.request.target.modifications.map((m) => m.kind + " " + m.amount_um).join() === "lead_crowning 8,profile_crowning 3" && Math.abs(retarget.result.target_um[0][0] + 11) < 1e-9,
      JSON.stringify({ kind: retarget.kind, parent: retarget.parent_job_id, target: retarget.request.target })
    );
    const targetMap = await page.$$eval("svg.heatmap", (svgs) => Array.from(svgs[1].querySelectorAll(".cell-value")).map((t) => t.textContent));
    // Tip row first: -11 at both ends of tip and root, -3 at mid-face (the profile crowning alone).
    check("the replay's target drawn", targetMap[0] === "-11.00" && targetMap[36] === "-11.00" && targetMap[40] === "-3.00", JSON.stringify(targetMap.slice(36)));
    await page.screenshot({ path: path.join(outDir, "dashboard-replay-target.png"), fullPage: true });

    // 4. A simulated closed loop run from the page.
    await page.click("text=Simulate a closed loop on this setup");
    await page.waitForSelector("svg.closed-loop, section.simulation p.error", { timeout: 180000 });
    check("simulated closed loop plotted", (await page.$$("svg.closed-loop")).length === 1, await page.textContent("section.simulation"));

    // 4b. Measuring machines' files (issue 15): a correction of the sample gear of shared/formats
    //     from its .mka file shows the file's ISO classes; the GDE file of the same flank given as
    //     the next part becomes a new linked job; the job downloads as GDE; the .mka file on a
    //     job of another gear, dropped on the panel, is refused, naming the header code.
    const samples = path.join(REPO, "tests", "formats", "data");
    const sampleGear = { teeth: 31, normal_module_mm: 4.5, normal_pressure_angle_deg: 20, helix_angle_deg: 20, hand: "right", face_width_mm: 40, tip_radius_mm: 78.726, root_radius_mm: 68.601 };
    const fromFile = await api(base, "POST", "/api/v1/corrections", {
      gear: sampleGear,
      wheel: { radius_mm: 350 },
      flank: "right",
      measurement: { file: { format: "mka", content: fs.readFileSync(path.join(samples, "sample_topography.mka"), "utf8") } },
      trace: { part_number: "4711-A", serial: "S0042", measured_at: "2026-11-22T07:45:00Z", file_name: "sample_topography.mka", machine_id: "RZ260-2" },
      tolerance: { rms_um: 0.05, iso_class: 11 },
    });
    const showById = async (id) => {
      await page.evaluate((n) => {
        window.location.hash = "job=" + n;
      }, id);
      await page.waitForSelector("body[data-job-shown='" + id + "']", { timeout: 30000 });
    };
    await showById(fromFile.id);
    const overall = await page.$$eval("table.iso1328 tr.iso-overall td.iso-class", (tds) => tds.map((td) => td.textContent));
    check("the .mka sample's measured flank is class 6", overall[0] === "6" && overall[1] === "6", JSON.stringify(overall));
    const traceShown = Object.fromEntries(await page.$$eval("table.summary tr", (trs) => trs.map((tr) => [tr.querySelector("th").textContent, tr.querySelector("td").textContent])));
    check(
      "the job's trace in its summary",
      traceShown["part number"] === "4711-A" && traceShown["serial"] === "S0042" && traceShown["measuring file"] === "sample_topography.mka" && traceShown["machine"] === "RZ260-2",
      JSON.stringify(traceShown)
    );
    check(
      "the tolerance and the verdicts in the summary",
      traceShown["tolerance"] === "rms 0.05 \u00b5m, ISO 1328-1 class 11" && traceShown["verdict measured"] === "FAIL (misses rms_um)" && traceShown["verdict predicted"] === fromFile.result.verdict.predicted.verdict + (fromFile.result.verdict.predicted.failed.length ? " (misses " + fromFile.result.verdict.predicted.failed.join(", ") + ")" : ""),
      JSON.stringify(traceShown)
    );
    await page.screenshot({ path: path.join(outDir, "dashboard-iso1328.png"), fullPage: true });
    // The GDE file of the same flank as a new correction of this setup: the answer carries the
    // job's tolerance and its verdicts.
    await page.setInputFiles("#new-correction-file", path.join(samples, "sample_topography.gde.xml"));
    await page.waitForFunction((old) => Number(document.body.getAttribute("data-new-correction")) > old, againId, { timeout: 60000 });
    const fromGde = await api(base, "GET", "/api/v1/corrections/" + (await page.getAttribute("body", "data-new-correction")));
    const gdeAnswer = Object.fromEntries(await page.$$eval("#new-correction-result table.answer tr", (trs) => trs.map((tr) => [tr.querySelector("th").textContent, tr.querySelector("td").textContent])));
    const verdictText = (v) => v.verdict + (v.failed.length ? " (misses " + v.failed.join(", ") + ")" : "");
    check(
      "new correction from a GDE file: tolerance verdicts shown",
      fromGde.request.measurement.file.format === "gde" && fromGde.trace.part_number === "4711-A" && fromGde.trace.file_name === "sample_topography.gde.xml" && gdeAnswer["verdict measured"] === verdictText(fromGde.result.verdict.measured) && gdeAnswer["verdict predicted"] === verdictText(fromGde.result.verdict.predicted),
      JSON.stringify(gdeAnswer)
    );
    await page.click("#export-gde");
    await page.waitForSelector("a[download='job" + fromFile.id + ".gde.xml']", { timeout: 30000 });
    const gdeText = await page.evaluate(async (name) => (await fetch(document.querySelector("a[download='" + name + "']").href)).text(), "job" + fromFile.id + ".gde.xml");
    check("the job downloads as GDE", /<GDE/.test(gdeText) && /kind="predicted"/.test(gdeText), gdeText.slice(0, 120));
    await page.setInputFiles("#next-part-file", path.join(samples, "sample_topography.gde.xml"));
    await page.waitForFunction((old) => Number(document.body.getAttribute("data-job-shown")) > old, fromFile.id, { timeout: 60000 });
    const gdeJob = await api(base, "GET", "/api/v1/corrections/" + (await page.getAttribute("body", "data-job-shown")));
    check(
      "a GDE file as the next part",
      gdeJob.request.measurement.file.format === "gde" && gdeJob.settings_source_job_id === fromFile.id && gdeJob.result.iso1328.measured.classes.overall === 6,
      JSON.stringify({ id: gdeJob.id, source: gdeJob.settings_source_job_id })
    );
    await showById(job.id);
    const errorsBefore = consoleErrors.length;
    // Dropped on the panel this time (the same path as a chosen file).
    await page.evaluate((text) => {
      const data = new DataTransfer();
      data.items.add(new File([text], "sample_topography.mka", { type: "application/octet-stream" }));
      document.querySelector(".next-part").dispatchEvent(new DragEvent("drop", { dataTransfer: data, bubbles: true, cancelable: true }));
    }, fs.readFileSync(path.join(samples, "sample_topography.mka"), "utf8"));
    await page.waitForSelector("#next-part-status.error", { timeout: 30000 });
    const refusal = await page.textContent("#next-part-status");
    // Chromium logs the refused request itself; that 422 is the answer this step asks for.
    for (const e of consoleErrors.splice(errorsBefore)) if (!/status of 422/.test(e)) consoleErrors.push(e);
    check("a file of another gear is refused with its header line", /422 invalid_file at measurement\.file\.content: file:line \d+: .*code 2[1-6]/.test(refusal), refusal);

    // 5. The printable report of the measured job.
    await page.goto(base + "/jobs/" + job.id + "/report", { waitUntil: "load" });
    await page.waitForSelector("body[data-ready]", { timeout: 30000 });
    check("report drawn", (await page.getAttribute("body", "data-ready")) === "true" && (await page.$$("svg.heatmap")).length === 3);
    await page.screenshot({ path: path.join(outDir, "report.png"), fullPage: true });
    await page.goto(base + "/jobs/" + fromFile.id + "/report", { waitUntil: "load" });
    await page.waitForSelector("body[data-ready]", { timeout: 30000 });
    const reportTrace = await page.$$eval("table.summary tr", (trs) => trs.map((tr) => tr.querySelector("th").textContent + "=" + tr.querySelector("td").textContent));
    check("the report names part, serial and measuring time", reportTrace.includes("part number=4711-A") && reportTrace.includes("serial=S0042") && reportTrace.includes("measured at=2026-11-22T07:45:00Z"), JSON.stringify(reportTrace));

    // 5b. The exact-model search of a job that ran it (its two exact predictions, a lost one as
    //     "\u2013") and of a job stored before the field existed ("\u2013"): the stored job answered
    //     so in flight.
    const summaryOfStored = async (id, edit) => {
      const stored = await api(base, "GET", "/api/v1/corrections/" + id);
      edit(stored.result);
      const url = base + "/api/v1/corrections/" + id;
      await page.route(url, (route) => route.fulfill({ status: 200, contentType: "application/json", body: JSON.stringify(stored) }));
      await page.goto(base + "/#job=" + id, { waitUntil: "load" });
      await page.waitForSelector("body[data-job-shown='" + id + "']", { timeout: 30000 });
      const shown = await page.$$eval("table.summary tr", (trs) => trs.map((tr) => [tr.querySelector("th").textContent, tr.querySelector("td").textContent]));
      await page.unroute(url);
      return shown;
    };
    const taken = "taken: the exact model at the linearisation point predicts 0.27 um against 9.1 um";
    const ran = await summaryOfStored(chainIds[0], (r) => {
      r.exact_search = { outcome: taken, regularised_predicted_rms_um: 9.1, searched_predicted_rms_um: null };
    });
    const ranRows = ran.filter((row) => row[0].startsWith("exact-model"));
    check(
      "a search that ran: its outcome and its two exact predictions",
      JSON.stringify(ranRows) === JSON.stringify([["exact-model search", taken], ["exact-model rms regularised / searched", "9.100 / \u2013 \u00b5m"]]),
      JSON.stringify(ranRows)
    );
    const older = await summaryOfStored(chainIds[1], (r) => {
      delete r.exact_search;
    });
    const olderRows = older.filter((row) => row[0].startsWith("exact-model"));
    check("a job stored before the search: not reported", JSON.stringify(olderRows) === JSON.stringify([["exact-model search", "\u2013"]]), JSON.stringify(olderRows));

    // 6. The offline report written by `gearloop report` (no server needed to view it).
    if (cliBin) {
      const file = path.join(outDir, "job-" + job.id + ".html");
      execFileSync(cliBin, ["--server", base, "report", String(job.id), "-o", file], { stdio: "ignore" });
      const offline = await context.newPage();
      const offlineErrors = [];
      offline.on("console", (msg) => {
        if (msg.type() === "error") offlineErrors.push(msg.text());
      });
      offline.on("pageerror", (err) => offlineErrors.push(err.message));
      await offline.goto("file://" + file, { waitUntil: "load" });
      await offline.waitForSelector("body[data-ready]", { timeout: 30000 });
      const ready = await offline.getAttribute("body", "data-ready");
      check("offline report drawn", ready === "true" && (await offline.$$("svg.heatmap")).length === 3, ready);
      check("offline report without errors", offlineErrors.length === 0, offlineErrors.join(" | "));
      await offline.screenshot({ path: path.join(outDir, "report-offline.png"), fullPage: true });
      await offline.close();
    }

    // 6b. A spiral-bevel pinion job (free-form generator): measured with hidden axis errors,
    // corrected; the page shows its machine, its grids and the axis curves A, B, X, Y, Z.
    const bevelJob = { side: "convex", published: true };
    const nominal = (await api(base, "POST", "/api/v1/bevel/conversions", { job: bevelJob })).motion;
    const erring = JSON.parse(JSON.stringify(nominal));
    erring.X_mm[0] += 0.008;
    erring.B_rad[0] -= (0.003 * Math.PI) / 180;
    const bevelMeasured = (await api(base, "POST", "/api/v1/bevel/evaluate", { job: bevelJob, motion: erring })).deviations_um;
    const bevel = await api(base, "POST", "/api/v1/corrections", {
      machine: { kind: "free-form-bevel-generator" },
      job: bevelJob,
      motion: nominal,
      measurement: { deviations_um: bevelMeasured },
      options: { default_max_order: 2 },
    });
    check("bevel job stored", bevel.id > 0 && bevel.result.machine_kind === "free-form-bevel-generator", JSON.stringify(bevel).slice(0, 200));
    await page.goto(base + "/#job=" + bevel.id, { waitUntil: "load" });
    await page.waitForSelector("body[data-job-shown='" + bevel.id + "']", { timeout: 30000 });
    const bevelText = await page.textContent("section.job-view");
    check("bevel job names its machine", /machine: free-form bevel generator/.test(bevelText) && /convex flank/.test(bevelText), bevelText.slice(0, 300));
    const bevelMaps = await page.$$eval("section.job-view svg.heatmap", (svgs) => svgs.map((s) => s.querySelectorAll("rect.cell").length));
    check("bevel grids drawn", bevelMaps.length === 3 && bevelMaps.every((n) => n === 45), JSON.stringify(bevelMaps));
    const bevelCurves = await page.$$eval("section.job-view svg.chart polyline.series", (ls) => ls.map((l) => l.getAttribute("data-name")));
    check("bevel axis curves", ["X", "Y", "Z", "A", "B"].every((a) => bevelCurves.includes(a)) && !bevelCurves.includes("C"), JSON.stringify(bevelCurves));
    await page.waitForSelector("body[data-motion-shown='" + bevel.id + "']", { timeout: 30000 });
    const bevelMotion = await page.$$eval(".axis-motion-curve", (boxes) => boxes.map((b) => b.getAttribute("data-axis") + ":" + b.querySelectorAll("polyline.series").length));
    check("bevel axis motion, commanded vs corrected", bevelMotion.join() === "A:3,B:3,X:3,Y:3,Z:3", JSON.stringify(bevelMotion));
    check("bevel 3-D view", (await page.$$("canvas.topo3d")).length === 3);
    await page.screenshot({ path: path.join(outDir, "dashboard-bevel.png"), fullPage: true });

    // 6b. The shaving view: the published pinion's diagonal modification and the cutter target it
    // needs, side by side (POST /api/v1/shaving/cutter-target).
    await page.goto(base + "/#shaving", { waitUntil: "load" });
    await page.waitForSelector("#shaving-compute", { timeout: 30000 });
    await page.click("#shaving-compute");
    await page.waitForSelector("body[data-shaving-shown]", { timeout: 30000 });
    const shavingMaps = await page.$$eval("div.shaving-maps svg.heatmap", (svgs) =>
      svgs.map((s) => ({ title: s.querySelector(".plot-title").textContent, cells: s.querySelectorAll("rect.cell").length, missing: s.querySelectorAll("rect.cell.missing").length, values: Array.from(s.querySelectorAll(".cell-value")).map((t) => t.textContent) }))
    );
    check("shaving: two maps side by side", shavingMaps.map((m) => m.title).join(",") === "pinion modification,cutter target", JSON.stringify(shavingMaps.map((m) => m.title)));
    const shavingAnswer = await api(base, "POST", "/api/v1/shaving/cutter-target", JSON.parse(await page.inputValue("#shaving-request")));
    // The tip row is drawn first: the cutter target's top-left cell is row 5, L1.
    check(
      "shaving: cutter target numbers, root row not generated",
      shavingMaps.length === 2 && shavingMaps[1].cells === 45 && shavingMaps[1].missing === 9 && Number(shavingMaps[1].values[0]) === Number(shavingAnswer.stock_target_um[4][0].toFixed(2)),
      JSON.stringify(shavingMaps[1] && shavingMaps[1].values.slice(0, 9))
    );
    check("shaving: pinion relief drawn", shavingMaps.length === 2 && shavingMaps[0].cells === 45 && shavingMaps[0].missing === 0 && Number(shavingMaps[0].values[0]) === Number(shavingAnswer.work_modification_um[4][0].toFixed(2)), JSON.stringify(shavingMaps[0] && shavingMaps[0].values.slice(0, 9)));
    const boxes = await page.$$eval("div.shaving-maps svg.heatmap", (svgs) => svgs.map((s) => s.getBoundingClientRect()).map((r) => ({ top: r.top, left: r.left, right: r.right })));
    check("shaving: the maps side by side", boxes.length === 2 && Math.abs(boxes[0].top - boxes[1].top) < 1 && boxes[0].right <= boxes[1].left, JSON.stringify(boxes));
    const shavingText = await page.textContent("section.shaving-view");
    check("shaving: crossed-axes angle and wheel radii", /5\.090 deg/.test(shavingText) && /fixed 355\.78 mm/.test(shavingText) && /75\.342 mm/.test(shavingText), shavingText.slice(0, 300));
    await page.screenshot({ path: path.join(outDir, "dashboard-shaving.png"), fullPage: true });
    // 6c. A split-bevel trajectory job (docs/split-bevel.md's wheel): the tool-centre paths and
    // tool axes in two projections, A and B along the face, the passes, the NC program. 3 levels x
    // 2 flanks = 6 passes of 21 stations; an axis at every 3rd station and the last: 8 per pass.
    const split = await api(base, "POST", "/api/v1/bevel/split-trajectory", {
      gear: { teeth: 75, pitch_angle_deg: 70, outer_transverse_module_mm: 40, face_width_mm: 240, mean_spiral_angle_deg: 35, hand: "right", pressure_angle_deg: 20 },
      tool: { radius_mm: 8, stock_mm: 0.2 },
      cut: { slot_index: 3, depth_levels: 3, steps: 21 },
      machine: { pivot_length_mm: 300 },
    });
    await page.goto(base + "/#job=" + split.job_id, { waitUntil: "load" });
    await page.waitForSelector("body[data-job-shown='" + split.job_id + "']", { timeout: 30000 });
    const projections = await page.$$eval("section.split-trajectory svg.split-projection", (svgs) =>
      svgs.map((s) => ({ title: s.querySelector(".plot-title").textContent, paths: s.querySelectorAll("polyline.tool-path").length, axes: s.querySelectorAll("line.tool-axis").length, points: Array.from(s.querySelectorAll("polyline.tool-path")).map((l) => l.getAttribute("points").split(" ").length) }))
    );
    check(
      "split trajectory: paths in two projections",
      projections.length === 2 && /X\u2013Y/.test(projections[0].title) && /X\u2013Z/.test(projections[1].title) && projections.every((p) => p.paths === 6 && p.points.every((n) => n === 21) && p.axes === 6 * 8),
      JSON.stringify(projections.map((p) => [p.title, p.paths, p.axes]))
    );
    const angleSeries = await page.$$eval("section.split-trajectory .split-angles polyline.series", (ls) => ls.map((l) => l.getAttribute("data-name")));
    check("split trajectory: A and B along the face", angleSeries.join() === "A convex,A concave,B convex,B concave", JSON.stringify(angleSeries));
    const passRows = await page.$$eval("table.split-passes tr[data-pass]", (trs) => trs.map((tr) => Array.from(tr.querySelectorAll("td")).map((td) => td.textContent)));
    const a0 = split.passes[0].points.map((q) => q.A_deg);
    check(
      "split trajectory: pass table",
      passRows.length === 6 && passRows[0][1] === "convex" && passRows[3][1] === "concave" && passRows[0][3] === "21" && passRows[0][5] === Math.min(...a0).toFixed(3) + " \u2026 " + Math.max(...a0).toFixed(3),
      JSON.stringify(passRows[0])
    );
    const nc = await page.evaluate(async (name) => {
      const link = document.querySelector("a[download='" + name + "']");
      return link ? (await fetch(link.href)).text() : "";
    }, "job" + split.job_id + ".nc");
    const served = await (await fetch(base + split.nc_location)).text();
    check("split trajectory: NC program downloads", nc.startsWith("%\n(GEARLOOP SPLIT-BEVEL 1)\n") && nc === served, nc.slice(0, 40));
    await page.screenshot({ path: path.join(outDir, "dashboard-split-trajectory.png"), fullPage: true });

    // 7. Unknown pages stay 404 and the API is untouched by the static routes.
    const missing = await fetch(base + "/static/nope.js");
    check("unknown asset is 404", missing.status === 404);

    check("no console errors", consoleErrors.length === 0, consoleErrors.join(" | "));

    // 8. A server that wants tokens: the page says so, and works once a read token is entered.
    const tokenTmp = fs.mkdtempSync(path.join(os.tmpdir(), "gearloop-web-token-"));
    const sha = (t) => require("crypto").createHash("sha256").update(t).digest("hex");
    const tokenFile = path.join(tokenTmp, "tokens.txt");
    fs.writeFileSync(tokenFile, "read " + sha("reader-secret") + " dashboard\nwrite " + sha("writer-secret") + " cmm\n");
    const guarded = await startServer(tokenTmp, ["--token-file", tokenFile]);
    try {
      const guardedJob = await api(guarded.base, "POST", "/api/v1/corrections", request, "writer-secret");
      const tokenPage = await context.newPage();
      await tokenPage.goto(guarded.base + "/", { waitUntil: "load" });
      await tokenPage.waitForSelector("#jobs td.error", { timeout: 30000 });
      check("missing token is explained", /401/.test(await tokenPage.textContent("#jobs td.error")));
      await tokenPage.fill("#token", "reader-secret");
      await tokenPage.dispatchEvent("#token", "change");
      await tokenPage.waitForSelector("#jobs tbody tr[data-job-id='" + guardedJob.id + "']", { timeout: 30000 });
      // The newest job opens by itself once the list loads.
      await tokenPage.waitForSelector("body[data-job-shown='" + guardedJob.id + "']", { timeout: 30000 });
      check("job shown with a read token", (await tokenPage.$$("svg.heatmap")).length === 3);
      await tokenPage.close();
    } finally {
      guarded.child.kill("SIGTERM");
    }
  } finally {
    if (context) await context.close();
    child.kill("SIGTERM");
  }
  console.log("screenshots in " + outDir);
  console.log(passed + " passed, " + failed + " failed");
  process.exit(failed === 0 ? 0 : 1);
}

main().catch((e) => {
  console.log("FAIL " + (e && e.stack ? e.stack : e));
  console.log(passed + " passed, " + (failed + 1) + " failed");
  process.exit(1);
});
