// clients/web/report.js: the printable report of one job. Draws from window.GEARLOOP_REPORT
// ({job, lineage}) when the page was written by `gearloop report`, otherwise fetches the job
// named by the address /jobs/{id}/report from the server that served the page.
"use strict";

(function () {
  const main = document.getElementById("report");

  function show(data) {
    main.textContent = "";
    main.appendChild(GearloopPlots.renderJob(data.job, data.lineage));
    const stamp = GearloopPlots.html("p", { class: "note", text: "Report generated " + new Date().toISOString() + " from job " + data.job.id + "." });
    main.appendChild(stamp);
    document.title = "gearloop job " + data.job.id;
    document.body.setAttribute("data-ready", "true");
  }

  function fail(message) {
    main.textContent = "";
    main.appendChild(GearloopPlots.html("p", { class: "error", text: message }));
    document.body.setAttribute("data-ready", "error");
  }

  async function getJson(path) {
    const headers = { Accept: "application/json" };
    const token = window.localStorage ? localStorage.getItem("gearloop.token") : null;
    if (token) headers.Authorization = "Bearer " + token;
    const res = await fetch(path, { headers });
    const body = await res.json().catch(() => null);
    if (!res.ok) {
      const e = body && body.error ? body.error : {};
      throw new Error(res.status + " " + (e.code || "") + ": " + (e.message || "request failed"));
    }
    return body;
  }

  // The full jobs of a lineage (summaries lack the measured rms), at most 20 of them.
  async function fullLineage(id) {
    let chain = [];
    try {
      chain = (await getJson("/api/v1/corrections/" + id + "/lineage")).jobs || [];
    } catch (e) {
      chain = [];
    }
    return Promise.all(chain.slice(-20).map((j) => getJson("/api/v1/corrections/" + j.id)));
  }

  async function load() {
    if (window.GEARLOOP_REPORT) return show(window.GEARLOOP_REPORT);
    const match = /^\/jobs\/(\d+)\/report/.exec(window.location.pathname);
    if (!match) return fail("No job: open /jobs/{id}/report.");
    try {
      const job = await getJson("/api/v1/corrections/" + match[1]);
      const lineage = await fullLineage(match[1]);
      show({ job, lineage: lineage.length ? lineage : [job] });
    } catch (e) {
      fail("Cannot load job " + match[1] + ": " + e.message);
    }
  }

  load();
})();
