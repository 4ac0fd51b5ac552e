// The fleet table from /api/v1/elevators (the full dashboard replaces this file).
"use strict";
fetch("/api/v1/elevators").then(r => r.json()).then(d => {
  const body = document.querySelector("#fleet tbody");
  for (const e of d.elevators) {
    const tr = document.createElement("tr");
    const v = e.verdict || {};
    for (const x of [e.name || e.id, v.level || "no model", v.mode || "", v.risk ? v.risk[0].toFixed(1) : "", e.last_time_text || e.last_time || ""]) {
      const td = document.createElement("td");
      td.textContent = x;
      tr.appendChild(td);
    }
    body.appendChild(tr);
  }
});
