// liftwatch dashboard: hand-written ES2020, no framework, no network beyond this server.
// Pages (hash routes): #/ the fleet sorted by risk; #/elevator/ID one elevator.
// Charts are inline SVG drawn here, sized to their box (redrawn on resize).
'use strict';

(() => {
  const API = '/api/v1';
  const FLEET_REFRESH_MS = 5000;
  const ELEVATOR_REFRESH_MS = 10000;
  const DAY = 86400;
  /** The elevator page's charts cover at most this many days back from the last data. */
  const RISK_WINDOW_DAYS = 90;
  /** Trip rows per request (the server caps a page at 100 000). */
  const RISK_PAGE = 20000;

  const $app = document.getElementById('app');
  const $err = document.getElementById('error');
  const $refresh = document.getElementById('refresh');

  // ---------------------------------------------------------------- formatting

  const ESC = { '&': '&amp;', '<': '&lt;', '>': '&gt;', '"': '&quot;', "'": '&#39;' };
  const esc = (s) => String(s ?? '').replace(/[&<>"']/g, (c) => ESC[c]);
  const fin = (v) => typeof v === 'number' && Number.isFinite(v);
  const pad = (n) => String(n).padStart(2, '0');
  const MONTHS = ['Jan', 'Feb', 'Mar', 'Apr', 'May', 'Jun', 'Jul', 'Aug', 'Sep', 'Oct', 'Nov', 'Dec'];

  const SUBSYSTEM = {
    motor: 'drive', brake: 'brake', friction: 'guide rails',
    sensor: 'sensors', unknown: 'machine (no single signature)',
  };
  /** A `sensor` verdict's or event's channel, in the library's words (`Signal::sensor`). */
  const CHANNEL = {
    speed: 'speed sensor (encoder)', direction: 'direction signal', voltage: 'motor voltage sensor',
    load: 'load-weighing sensor', door: 'door status signal', floor: 'floor indicator', current: 'motor current sensor',
  };
  const channelWords = (c) => CHANNEL[c] || `${c} sensor`;
  /** `sensors: motor voltage sensor` for a sensor mode naming its channel, else the subsystem. */
  const modeText = (mode, channel) =>
    (SUBSYSTEM[mode] || mode || '') + (mode === 'sensor' && channel ? `: ${channelWords(channel)}` : '');
  const MACHINE = ['motor', 'brake', 'friction'];
  const MODE_COLOR = { motor: '#1f5fbf', brake: '#c2410c', friction: '#7e3fb3' };
  const LEVEL_RANK = { alarm: 3, advisory: 2, normal: 1, none: 0 };

  /** Three significant digits, plainly (as the CLI's `sig`). */
  function sig(v) {
    if (!fin(v)) return 'n/a';
    const a = Math.abs(v);
    if (a === 0) return '0';
    if (a < 1e-3 || a >= 1e6) return v.toExponential(2);
    const d = Math.max(0, 2 - Math.floor(Math.log10(a)));
    return v.toFixed(d);
  }

  function signed(v, d) {
    if (!fin(v)) return 'n/a';
    const s = v.toFixed(d);
    return (v >= 0 && !s.startsWith('-') ? '+' : '') + s.replace('-', '\u2212');
  }

  function num(v, d = 1) {
    return fin(v) ? v.toFixed(d).replace('-', '\u2212') : 'n/a';
  }

  /** Decimals for a drift in `unit`: N whole, percent one decimal. */
  const driftDecimals = (unit) => (unit === 'N' ? 0 : 1);

  /** `Kd +4.1 ± 0.7 %`, `brake drag +180 ± 40 N`, `Kd n/a`. */
  function driftText(d) {
    if (!d) return 'n/a';
    if (!fin(d.value)) return `${d.quantity} n/a`;
    const k = driftDecimals(d.unit);
    const se = fin(d.se) ? ` \u00b1 ${d.se.toFixed(k)}` : '';
    return `${d.quantity} ${signed(d.value, k)}${se} ${d.unit}`;
  }

  /** The UTC offset (s) of an RFC 3339 text, null without one. */
  function offsetOf(text) {
    if (typeof text !== 'string') return null;
    const m = /(Z|([+-])(\d\d):?(\d\d))$/.exec(text.trim());
    if (!m) return null;
    if (m[1] === 'Z') return 0;
    const s = (Number(m[3]) * 3600 + Number(m[4]) * 60);
    return m[2] === '-' ? -s : s;
  }

  const isCal = (t) => fin(t) && t >= 1e8 && t < 1e11;

  function zoneName(off) {
    if (!off) return 'UTC';
    const a = Math.abs(off);
    return `UTC${off < 0 ? '\u2212' : '+'}${pad(Math.floor(a / 3600))}:${pad(Math.floor((a % 3600) / 60))}`;
  }

  /** The clock of one elevator: its UTC offset, read from its `*_text` fields. */
  function clockOf(summary) {
    const off = offsetOf(summary && summary.last_time_text);
    return { off: off ?? 0, known: off !== null };
  }

  const local = (t, off) => new Date(Math.floor(t + off) * 1000);

  /** `2026-03-03 14:05 UTC+01:00`, or `day 12.41 of data` for a relative clock. */
  function instantText(t, clock) {
    if (!fin(t)) return 'n/a';
    if (!isCal(t)) return `day ${(t / DAY).toFixed(2)} of data`;
    const d = local(t, clock.off);
    return `${d.getUTCFullYear()}-${pad(d.getUTCMonth() + 1)}-${pad(d.getUTCDate())} ` +
      `${pad(d.getUTCHours())}:${pad(d.getUTCMinutes())} ${zoneName(clock.off)}`;
  }

  /** `3 Mar 2026`, or `day 12.4 of data`. */
  function dayText(t, clock) {
    if (!fin(t)) return 'n/a';
    if (!isCal(t)) return `day ${(t / DAY).toFixed(1)} of data`;
    const d = local(t, clock.off);
    return `${d.getUTCDate()} ${MONTHS[d.getUTCMonth()]} ${d.getUTCFullYear()}`;
  }

  /** An RFC 3339 text as `2026-03-03 14:05 UTC+01:00`; the text itself when it does not parse. */
  function rfcText(text) {
    const off = offsetOf(text);
    const ms = Date.parse(text);
    if (off === null || !Number.isFinite(ms)) return String(text);
    return instantText(ms / 1000, { off });
  }

  /** A time given as seconds with an optional `*_text` sibling. */
  function whenText(t, text, clock) {
    if (typeof text === 'string' && text) return rfcText(text);
    if (!fin(t)) return 'no data yet';
    return instantText(t, clock);
  }

  function durationText(s) {
    if (!fin(s)) return 'unknown';
    const a = Math.abs(s);
    let out;
    if (a < 90) out = `${Math.round(a)} s`;
    else if (a < 90 * 60) out = `${Math.round(a / 60)} min`;
    else if (a < 36 * 3600) out = `${(a / 3600).toFixed(1)} h`;
    else out = `${(a / DAY).toFixed(1)} days`;
    return s < 0 ? `\u2212${out}` : out;
  }

  /** An elevator without a stored sample has no last time (the server may send 0 then). */
  function normalize(s) {
    if (s && s.samples === 0 && !s.last_time_text) s.last_time = null;
    return s;
  }

  const levelOf = (s) => (s && s.verdict && s.verdict.level) || 'none';
  const levelWord = (lv) => (lv === 'none' ? 'no model' : lv);
  /** A model but no verdict yet: the monitor has not watched a sample. */
  const waiting = (s) => s && !s.verdict && s.model_version != null;
  const badge = (lv, s) => `<span class="badge lv-${esc(lv)}">${esc(waiting(s) ? 'no verdict yet' : levelWord(lv))}</span>`;
  const displayName = (s) => (s.name && s.name !== s.id ? s.name : s.id);
  const elevatorHref = (id) => `#/elevator/${encodeURIComponent(id)}`;

  // ---------------------------------------------------------------- verdict reading

  /** The drift the verdict names (its mode's), else the one furthest from zero in SEs. */
  function headlineDrift(v) {
    if (!v || !Array.isArray(v.drifts)) return null;
    const own = v.drifts.find((d) => d.mode === v.mode);
    if (own) return { drift: own, own: true };
    let best = null;
    let bestZ = -1;
    for (const d of v.drifts) {
      if (!fin(d.value)) continue;
      const z = fin(d.se) && d.se > 0 ? Math.abs(d.value) / d.se : Math.abs(d.value);
      if (z > bestZ) { bestZ = z; best = d; }
    }
    return best ? { drift: best, own: false } : null;
  }

  /** R relative to the advisory level (1 = at the advisory level). */
  function riskRatio(v) {
    if (!v || !Array.isArray(v.risk)) return null;
    const [r, adv] = v.risk;
    return fin(r) && fin(adv) && adv > 0 ? r / adv : null;
  }

  const shortLevel = (name) => String(name || '').replace(/ level$/, '');

  /**
   * The next level the verdict's mode (every mode at normal/unknown) is forecast to reach:
   * `{text, days}`; levels at or below the current one are skipped.
   */
  function nextCrossing(v) {
    const fc = v && v.forecast;
    if (!fc || !Array.isArray(fc.modes)) return null;
    const skip = v.level === 'alarm' ? 2 : v.level === 'advisory' ? 1 : 0;
    const modes = fc.modes.filter((f) => (MACHINE.includes(v.mode) ? f.mode === v.mode : true));
    let best = null;
    let reached = null;
    let beyond = false;
    for (const f of modes) {
      (f.crossings || []).forEach((c, i) => {
        if (i < skip) return;
        const w = c.when || {};
        if (w.status === 'at' && fin(w.time) && fin(fc.now)) {
          const days = (w.time - fc.now) / DAY;
          if (!best || days < best.days) best = { f, c, days, w };
        } else if (w.status === 'reached') {
          reached = reached || { f, c };
        } else if (w.status === 'not_within_horizon') {
          beyond = true;
        }
      });
    }
    const who = (f) => (MACHINE.includes(v.mode) ? '' : ` (${f.quantity})`);
    if (best) {
      const early = fin(best.w.early) ? (best.w.early - fc.now) / DAY : null;
      const late = fin(best.w.late) ? (best.w.late - fc.now) / DAY : null;
      const range = early !== null
        ? ` (${Math.max(0, early).toFixed(0)}\u2013${late !== null ? late.toFixed(0) : '?'} days)` : '';
      const when = best.days < 1 ? 'within a day' : `in ~${best.days.toFixed(0)} day${best.days < 1.5 ? '' : 's'}`;
      return {
        text: `${shortLevel(best.c.name)} ${when}${who(best.f)}`,
        range, days: best.days,
      };
    }
    if (reached) return { text: `${shortLevel(reached.c.name)} reached${who(reached.f)}`, range: '', days: 0 };
    const nextName = modes.length && modes[0].crossings && modes[0].crossings[skip]
      ? `${shortLevel(modes[0].crossings[skip].name)}: ` : '';
    if (beyond) return { text: `${nextName}not within the horizon`, range: '', days: Infinity };
    return { text: `${nextName}no rising trend`, range: '', days: Infinity };
  }

  /** The forecast sentence of one mode, as the CLI writes it. */
  function modeForecastText(f, now, clock) {
    const t = f.trend;
    if (!t) return '';
    const rate = `${f.quantity} ${signed(t.slope_per_day, 2)} \u00b1 ${num(t.slope_se, 2)} ${f.unit}/day over the blocks since ${dayText(t.since, clock)}`;
    const items = (f.crossings || []).map((c) => {
      const level = `the ${c.name} (${f.quantity} ${fin(c.threshold) ? signed(c.threshold, 1) : 'n/a'} ${f.unit})`;
      const w = c.when || {};
      switch (w.status) {
        case 'reached': return `${level} is reached`;
        case 'no_trend': return `${level}: no rising trend`;
        case 'not_within_horizon': return `${level}: not within the forecast horizon`;
        case 'at': {
          if (!fin(w.time) || !fin(now)) return `${level}: no date`;
          const days = (x) => ((x - now) / DAY).toFixed(0);
          const late = fin(w.late) ? `${days(w.late)} days` : 'beyond the horizon';
          const dates = isCal(w.time)
            ? `, ${dayText(w.early, clock)} to ${fin(w.late) ? dayText(w.late, clock) : 'later'}` : '';
          const due = w.time <= now ? 'is due now' : `in ~${days(w.time)} days`;
          return `${level} ${due} (${days(w.early)} to ${late}${dates}, 95 % interval)`;
        }
        default: return `${level}: ${esc(w.status || 'unknown')}`;
      }
    });
    return `at this rate (${rate}): ${items.join('; ')}.`;
  }

  function forecastSentence(v, clock) {
    const fc = v.forecast;
    if (!fc || !Array.isArray(fc.modes)) return 'no forecast.';
    const modes = fc.modes
      .filter((f) => f.mode === v.mode || !MACHINE.includes(v.mode))
      .filter((f) => f.trend && fin(f.trend.slope_per_day))
      .filter((f) => (f.crossings || []).some((c) => c.when && ((c.when.status === 'at' && fin(c.when.time)) || c.when.status === 'not_within_horizon')));
    if (!modes.length) return 'no drift is rising distinguishably from zero; no level is forecast within the horizon.';
    return modes.map((f) => modeForecastText(f, fc.now, clock)).join(' ');
  }

  function evidenceSentence(v) {
    const [r, adv, alm] = v.risk || [];
    let s = `risk R = ${sig(r)} (advisory level ${sig(adv)}, alarm level ${sig(alm)})`;
    if (fin(v.cusum_ratio) && v.cusum_ratio >= 0.5) {
      s += `; the sequential test stands at G/h = ${v.cusum_ratio.toFixed(2)} (1 decides) over ${v.changed_trips} trips`;
      if (fin(v.misfit) && v.misfit > 1) {
        s += `; the trips the drifts are read from depart from one mode's signature (misfit ${v.misfit.toFixed(1)}), which widens their standard errors ${Math.sqrt(v.misfit).toFixed(1)} times`;
      }
    }
    const [ok, refused] = v.trips || [];
    if (fin(ok)) s += `; ${ok} trips taken as machine evidence, ${fin(refused) ? refused : 0} refused as sensor-implausible`;
    return `${s}.`;
  }

  // ---------------------------------------------------------------- fetching and errors

  class ApiError extends Error {}

  async function api(path) {
    let res;
    try {
      res = await fetch(API + path, { headers: { Accept: 'application/json' }, cache: 'no-store' });
    } catch (e) {
      throw new ApiError(`${API}${path}: the server does not answer (${e.message})`);
    }
    const body = await res.text();
    let json = null;
    try { json = body ? JSON.parse(body) : null; } catch (_) { json = null; }
    if (!res.ok) {
      const why = json && json.error ? json.error : (body.slice(0, 200) || res.statusText);
      const err = new ApiError(`${API}${path}: ${res.status} ${why}`);
      err.status = res.status;
      throw err;
    }
    if (json === null) throw new ApiError(`${API}${path}: the answer is not JSON`);
    return json;
  }

  const errors = new Map();

  function setError(key, msg) {
    if (msg) errors.set(key, msg); else errors.delete(key);
    const all = [...errors.values()];
    $err.hidden = all.length === 0;
    $err.innerHTML = all.map((m) => `<div>Error: ${esc(m)}</div>`).join('');
  }

  function clearErrors() {
    errors.clear();
    setError('', null);
  }

  function stamp(ok) {
    const d = new Date();
    const t = `${pad(d.getHours())}:${pad(d.getMinutes())}:${pad(d.getSeconds())}`;
    $refresh.textContent = ok ? `updated ${t}` : `update failed ${t}: showing older data`;
  }

  /** Replaces an element's content only when it changed: no flicker, focus and scroll kept. */
  function put(el, html) {
    if (!el) return;
    if (el.__html !== html) {
      el.innerHTML = html;
      el.__html = html;
      labelTables(el);
    }
  }

  /** Gives each cell of a data table its column's name, shown before it on a phone. */
  function labelTables(root) {
    for (const t of root.querySelectorAll('table.data')) {
      const names = [...t.querySelectorAll('thead th')].map((th) => th.textContent.trim());
      for (const tr of t.querySelectorAll('tbody tr')) {
        [...tr.children].forEach((td, i) => { if (names[i]) td.setAttribute('data-label', names[i]); });
      }
    }
  }

  // ---------------------------------------------------------------- routing

  let page = null; // { stop(), resize() }

  function route() {
    if (page) page.stop();
    clearErrors();
    const h = location.hash || '#/';
    const m = /^#\/elevator\/([^/?#]+)/.exec(h);
    document.getElementById('nav-fleet').setAttribute('aria-current', m ? 'false' : 'page');
    page = m ? elevatorPage(decodeURIComponent(m[1])) : fleetPage();
    window.scrollTo(0, 0);
  }

  window.addEventListener('hashchange', route);
  let resizeTimer = null;
  window.addEventListener('resize', () => {
    clearTimeout(resizeTimer);
    resizeTimer = setTimeout(() => page && page.resize && page.resize(), 150);
  });

  /** A polling loop that stops with its page. */
  function poller(fn, ms) {
    let alive = true;
    let timer = null;
    const tick = async () => {
      if (!alive) return;
      try { await fn(); } catch (e) { console.error(e); }
      if (alive) timer = setTimeout(tick, ms);
    };
    tick();
    return () => { alive = false; clearTimeout(timer); };
  }

  // ---------------------------------------------------------------- fleet page

  function sortFleet(list) {
    return list
      .map((s, i) => ({ s, i }))
      .sort((a, b) => {
        const la = LEVEL_RANK[levelOf(a.s)] ?? 0;
        const lb = LEVEL_RANK[levelOf(b.s)] ?? 0;
        if (la !== lb) return lb - la;
        const ra = riskRatio(a.s.verdict) ?? -1;
        const rb = riskRatio(b.s.verdict) ?? -1;
        if (ra !== rb) return rb - ra;
        return a.i - b.i;
      })
      .map((x) => x.s);
  }

  function searchText(s) {
    const v = s.verdict;
    return [s.id, s.name, s.group, levelWord(levelOf(s)), v && v.mode, v && SUBSYSTEM[v.mode], v && v.channel, v && v.channel && channelWords(v.channel)]
      .filter(Boolean).join(' ').toLowerCase();
  }

  function riskBar(v) {
    if (!v || !Array.isArray(v.risk)) return '';
    const [r, adv, alm] = v.risk;
    if (!fin(r) || !fin(alm) || alm <= 0) return '';
    // Position on a log scale from advisory/100 to the alarm level, so the advisory mark shows.
    const lo = Math.log10(Math.max(adv / 100, 1e-9));
    const hi = Math.log10(alm);
    const x = (val) => Math.min(1, Math.max(0, (Math.log10(Math.max(val, 1e-12)) - lo) / (hi - lo)));
    const lv = v.level;
    const color = lv === 'alarm' ? 'var(--alarm)' : lv === 'advisory' ? 'var(--advisory)' : 'var(--normal)';
    return `<span class="riskbar" title="R ${sig(r)}: advisory at ${sig(adv)}, alarm at ${sig(alm)}">` +
      `<i style="width:${(100 * x(r)).toFixed(1)}%;background:${color}"></i></span>` +
      `<span class="small muted num">R ${sig(r)} / adv ${sig(adv)}</span>`;
  }

  function fleetRow(s) {
    const v = s.verdict;
    const lv = levelOf(s);
    const clock = clockOf(s);
    const name = displayName(s);
    const sub = [name !== s.id ? s.id : null, s.group].filter(Boolean).map(esc).join(' \u00b7 ');
    let why;
    let fc = '<span class="muted">\u2014</span>';
    let inspect = waiting(s) ? '<span class="muted">wait for the first trips to be watched</span>'
      : '<span class="muted">upload a model (<code>liftwatch fit</code>) to start monitoring</span>';
    if (v) {
      const hd = headlineDrift(v);
      const since = fin(v.since) ? ` <span class="nowrap">since ${esc(dayText(v.since, clock))}</span>` : '';
      if (lv === 'normal') {
        why = `<span>healthy reference</span>` +
          (hd ? `<br><span class="small muted">largest drift ${esc(driftText(hd.drift))}</span>` : '');
      } else {
        const mode = SUBSYSTEM[v.mode] || v.mode;
        why = v.mode === 'sensor'
          ? `<b>${esc(mode)}</b>: <span class="channel">${esc(v.channel ? channelWords(v.channel) : 'the data look wrong')}</span>${v.channel ? '' : since}`
          : `<b>${esc(mode)}</b>: <span class="drift num">${esc(hd ? driftText(hd.drift) : 'drift n/a')}</span>${since}`;
      }
      const nc = nextCrossing(v);
      if (nc) fc = `<span>${esc(nc.text)}</span>${nc.range ? `<br><span class="small muted">${esc(nc.range.trim())}</span>` : ''}`;
      inspect = `<span class="inspect">${esc(v.inspect)}</span>`;
      if (Array.isArray(v.caveats) && v.caveats.length) {
        inspect += `<br><span class="small muted">${v.caveats.length} caveat${v.caveats.length > 1 ? 's' : ''} (see page)</span>`;
      }
    } else {
      why = waiting(s) ? `<span class="muted">model v${esc(s.model_version)} active, no data watched yet</span>`
        : '<span class="muted">no active model yet</span>';
    }
    const lastText = whenText(s.last_time, s.last_time_text, clock);
    const zoned = /^(.*) (UTC\S*)$/.exec(lastText);
    const last = fin(s.last_time) || s.last_time_text
      ? `${zoned ? `<span class="nowrap">${esc(zoned[1])}</span> <span class="nowrap">${esc(zoned[2])}</span>` : esc(lastText)}<br><span class="small muted">lag ${esc(durationText(s.lag_s))}</span>`
      : '<span class="muted">no data yet</span>';
    const usage = fin(s.trips_per_day) || fin(s.door_cycles_per_day)
      ? `<span class="nowrap">${esc(num(s.trips_per_day, 0))} trips/day</span>` +
        `<br class="wide-only"><span class="small muted"> ${esc(num(s.door_cycles_per_day, 0))} door cycles/day</span>`
      : '<span class="muted">\u2014</span>';
    const events = fin(s.open_events) && s.open_events > 0
      ? `<br><span class="small">${s.open_events} open event${s.open_events > 1 ? 's' : ''}</span>` : '';
    return `<tr class="row-${esc(lv)}" data-id="${esc(s.id)}">` +
      `<td class="level" data-label="Level">${badge(lv, s)}${riskBar(v)}</td>` +
      `<td class="name" data-label="Elevator"><a href="${elevatorHref(s.id)}">${esc(name)}</a>` +
      `${sub ? `<br><span class="small muted">${sub}</span>` : ''}${events}</td>` +
      `<td class="why" data-label="Why">${why}</td>` +
      `<td class="fc" data-label="Forecast">${fc}</td>` +
      `<td class="inspect wide" data-label="Inspect">${inspect}</td>` +
      `<td class="last" data-label="Last data">${last}</td>` +
      `<td class="usage wide" data-label="Usage">${usage}</td>` +
      '</tr>';
  }

  function fleetPage() {
    document.title = 'Fleet \u2014 liftwatch';
    $app.innerHTML =
      '<div class="fleet-head"><h1>Fleet</h1><div class="counts" id="counts"></div>' +
      '<label class="filter"><span class="small muted">Filter</span>' +
      '<input id="filter" type="search" placeholder="id, name, group, level or mode" autocomplete="off"></label></div>' +
      '<p class="small muted" id="fleet-note">Sorted by risk, highest first: the elevator at the top needs a visit first. ' +
      '<span class="more">Times are each elevator\u2019s local time (zone shown); drifts are physical (Kd and friction in %, brake drag in N) \u00b1 one standard error.</span></p>' +
      '<div id="fleet-body"></div>';
    const $counts = document.getElementById('counts');
    const $body = document.getElementById('fleet-body');
    const $filter = document.getElementById('filter');
    let list = null;
    let levelFilter = null;

    function render() {
      if (!list) return;
      const counts = { alarm: 0, advisory: 0, normal: 0, none: 0 };
      list.forEach((s) => { counts[levelOf(s)] = (counts[levelOf(s)] || 0) + 1; });
      put($counts, ['alarm', 'advisory', 'normal', 'none'].map((lv) =>
        `<button type="button" data-level="${lv}" aria-pressed="${levelFilter === lv}" title="show only ${levelWord(lv)}">` +
        `<span class="badge lv-${lv}">${levelWord(lv)}</span><b class="num">${counts[lv]}</b></button>`).join('') +
        `<span class="small muted" style="align-self:center">${list.length} elevator${list.length === 1 ? '' : 's'}</span>`);
      if (!list.length) {
        put($body, '<div class="empty"><p><b>No elevators yet.</b></p>' +
          '<p>Stream one with <code>liftwatch replay --input RAW.csv --id ID --to ' + esc(location.origin) + '</code> ' +
          '(a simulated log: <code>liftwatch simulate --out sim</code>), then upload its model from <code>liftwatch fit</code>.</p></div>');
        return;
      }
      const q = $filter.value.trim().toLowerCase();
      const shown = sortFleet(list).filter((s) =>
        (!levelFilter || levelOf(s) === levelFilter) && (!q || searchText(s).includes(q)));
      const rows = shown.map(fleetRow).join('');
      put($body, '<div class="table-wrap"><table class="fleet"><thead><tr>' +
        '<th>Level</th><th>Elevator</th><th>Why: subsystem, drift \u00b1 SE, since</th><th>Forecast</th>' +
        '<th>Inspect</th><th>Last data</th><th>Usage</th></tr></thead><tbody>' +
        (rows || '<tr><td colspan="7" class="muted">No elevator matches the filter.</td></tr>') +
        '</tbody></table></div>');
    }

    $filter.addEventListener('input', render);
    $counts.addEventListener('click', (e) => {
      const b = e.target.closest('button[data-level]');
      if (!b) return;
      levelFilter = levelFilter === b.dataset.level ? null : b.dataset.level;
      render();
    });
    $body.addEventListener('click', (e) => {
      if (e.target.closest('a')) return;
      const tr = e.target.closest('tr[data-id]');
      if (tr) location.hash = elevatorHref(tr.dataset.id);
    });

    const stop = poller(async () => {
      try {
        const j = await api('/elevators');
        list = Array.isArray(j.elevators) ? j.elevators.map(normalize) : [];
        setError('fleet', null);
        stamp(true);
      } catch (e) {
        setError('fleet', e.message);
        stamp(false);
        if (!list) put($body, '<p class="muted">The fleet could not be loaded (see the error above); retrying every few seconds.</p>');
      }
      render();
    }, FLEET_REFRESH_MS);
    return { stop, resize() {} };
  }

  // ---------------------------------------------------------------- SVG charts

  const svgNS = 'http://www.w3.org/2000/svg';
  void svgNS;

  /** Tick positions for a time axis from x0 to x1 (s) over `px` pixels. */
  function timeTicks(x0, x1, px, clock) {
    const span = Math.max(x1 - x0, 1);
    const steps = [600, 1800, 3600, 3 * 3600, 6 * 3600, 12 * 3600, DAY, 2 * DAY, 5 * DAY, 7 * DAY,
      14 * DAY, 30 * DAY, 60 * DAY, 91 * DAY, 182 * DAY, 365 * DAY];
    const want = Math.max(2, Math.floor(px / 70));
    const step = steps.find((s) => span / s <= want) || steps[steps.length - 1];
    const off = isCal(x0) ? clock.off : 0;
    const first = Math.ceil((x0 + off) / step) * step - off;
    const ticks = [];
    for (let t = first; t <= x1 + 1e-6 && ticks.length < 60; t += step) ticks.push(t);
    const label = (t) => {
      if (isCal(t)) {
        const d = local(t, clock.off);
        if (step < DAY) {
          const hm = `${pad(d.getUTCHours())}:${pad(d.getUTCMinutes())}`;
          return hm === '00:00' ? `${d.getUTCDate()} ${MONTHS[d.getUTCMonth()]}` : hm;
        }
        return `${d.getUTCDate()} ${MONTHS[d.getUTCMonth()]}`;
      }
      if (step < DAY) return `${(t / DAY).toFixed(2)}`;
      return `${Math.round(t / DAY)}`;
    };
    return { ticks, label, title: isCal(x0) ? `date and time (${zoneName(clock.off)})` : 'day of data' };
  }

  function niceStep(span, n) {
    const raw = span / Math.max(n, 1);
    const p = 10 ** Math.floor(Math.log10(raw));
    const m = raw / p;
    return (m < 1.5 ? 1 : m < 3 ? 2 : m < 7 ? 5 : 10) * p;
  }

  function quantile(sorted, q) {
    if (!sorted.length) return NaN;
    const i = Math.min(sorted.length - 1, Math.max(0, Math.round(q * (sorted.length - 1))));
    return sorted[i];
  }

  /**
   * A line chart. opts: {width, height, x0, x1, clock, yLog, y0, y1, yTitle,
   * series: [{label, color, dash, width, marker, points: [[x, y]]}],
   * hlines: [{y, label, color, dash}], bands: [{x0, x1, fill}], gapS}.
   * Series are thinned to the min and max of each pixel column; gaps longer than gapS break lines.
   */
  function lineChart(o) {
    const W = Math.max(240, Math.round(o.width));
    const H = o.height;
    const m = { l: 56, r: 12, t: 10, b: 40 };
    const ph = H - m.t - m.b;
    const { x0, x1 } = o;
    const floor = o.yLog ? o.y0 : -Infinity;
    const ty = (y) => (o.yLog ? Math.log10(Math.max(y, floor)) : y);
    const Y0 = ty(o.y0);
    const Y1 = ty(o.y1);
    // y ticks first: the left margin fits their longest label beside the axis title
    let yt = [];
    let stepDecimals = 0;
    if (o.yLog) {
      for (let e = Math.floor(Y0); e <= Math.ceil(Y1); e++) {
        const v = 10 ** e;
        if (ty(v) >= Y0 - 1e-9 && ty(v) <= Y1 + 1e-9) yt.push(v);
      }
      if (yt.length > 6) yt = yt.filter((_, i) => i % 2 === 0);
    } else {
      const st = niceStep(o.y1 - o.y0, Math.max(2, Math.floor(ph / 45)));
      stepDecimals = Math.max(0, -Math.floor(Math.log10(st) + 1e-9));
      for (let v = Math.ceil(o.y0 / st) * st; v <= o.y1 + st * 1e-6; v += st) yt.push(Math.abs(v) < st * 1e-9 ? 0 : v);
    }
    const yl = (v) => (o.yLog ? (v >= 1e4 || v < 1e-2 ? `1e${Math.round(Math.log10(v))}` : sig(v)) : v.toFixed(stepDecimals).replace('-', '\u2212'));
    const longest = yt.reduce((n, v) => Math.max(n, yl(v).length), 1);
    m.l = Math.round((o.yTitle ? 24 : 8) + longest * 7.2 + 8);
    const pw = W - m.l - m.r;
    const sx = (x) => m.l + ((x - x0) / Math.max(x1 - x0, 1e-9)) * pw;
    const sy = (y) => m.t + ph - ((ty(y) - Y0) / Math.max(Y1 - Y0, 1e-12)) * ph;
    const clampY = (py) => Math.min(m.t + ph + 2, Math.max(m.t - 2, py));
    const parts = [];
    parts.push(`<svg class="chart" xmlns="http://www.w3.org/2000/svg" width="${W}" height="${H}" viewBox="0 0 ${W} ${H}" role="img" aria-label="${esc(o.aria || '')}">`);
    parts.push(`<defs><clipPath id="${o.id}-clip"><rect x="${m.l}" y="${m.t - 3}" width="${pw}" height="${ph + 6}"/></clipPath></defs>`);
    for (const b of o.bands || []) {
      const a = Math.max(sx(b.x0), m.l);
      const z = Math.min(sx(b.x1), m.l + pw);
      if (z > a) parts.push(`<rect x="${a.toFixed(1)}" y="${m.t}" width="${(z - a).toFixed(1)}" height="${ph}" fill="${b.fill}"/>`);
    }
    // y grid and labels
    parts.push('<g class="grid">');
    for (const v of yt) {
      const y = sy(v).toFixed(1);
      parts.push(`<line x1="${m.l}" x2="${m.l + pw}" y1="${y}" y2="${y}"/>`);
    }
    parts.push('</g>');
    for (const v of yt) parts.push(`<text x="${m.l - 6}" y="${(sy(v) + 4).toFixed(1)}" text-anchor="end" font-size="12">${esc(yl(v))}</text>`);
    // x ticks
    const tt = timeTicks(x0, x1, pw, o.clock);
    let lastRight = -Infinity;
    for (const t of tt.ticks) {
      const x = sx(t);
      parts.push(`<line class="axis" x1="${x.toFixed(1)}" x2="${x.toFixed(1)}" y1="${m.t + ph}" y2="${m.t + ph + 4}"/>`);
      const lab = tt.label(t);
      const w = lab.length * 7;
      // centred under its tick; at the right edge it ends there instead of being dropped
      const atEdge = x + w / 2 > W - 2;
      const left = atEdge ? W - 2 - w : x - w / 2;
      if (left > lastRight + 4 && x <= W) {
        parts.push(`<text x="${(atEdge ? W - 2 : x).toFixed(1)}" y="${m.t + ph + 17}" text-anchor="${atEdge ? 'end' : 'middle'}" font-size="12">${esc(lab)}</text>`);
        lastRight = left + w;
      }
    }
    parts.push(`<text x="${m.l + pw / 2}" y="${H - 4}" text-anchor="middle" font-size="12" fill="#5b6470">${esc(tt.title)}</text>`);
    if (o.yTitle) parts.push(`<text transform="translate(13 ${m.t + ph / 2}) rotate(-90)" text-anchor="middle" font-size="12">${esc(o.yTitle)}</text>`);
    parts.push(`<line class="axis" x1="${m.l}" x2="${m.l + pw}" y1="${m.t + ph}" y2="${m.t + ph}"/>`);
    parts.push(`<line class="axis" x1="${m.l}" x2="${m.l}" y1="${m.t}" y2="${m.t + ph}"/>`);
    // horizontal reference lines; a label too near one placed already goes to the right end
    const placed = [];
    for (const h of o.hlines || []) {
      if (!fin(h.y)) continue;
      const ty2 = ty(h.y);
      if (ty2 < Y0 || ty2 > Y1) continue;
      const y = sy(h.y).toFixed(1);
      parts.push(`<line x1="${m.l}" x2="${m.l + pw}" y1="${y}" y2="${y}" stroke="${h.color}" stroke-width="1.5" stroke-dasharray="${h.dash || ''}"/>`);
      if (h.label) {
        const ly = Number(y) - 4;
        const left = !placed.some((p) => p.left && Math.abs(p.y - ly) < 14);
        placed.push({ y: ly, left });
        const x = left ? m.l + 4 : m.l + pw - 4;
        parts.push(`<text x="${x.toFixed(1)}" y="${ly.toFixed(1)}" text-anchor="${left ? 'start' : 'end'}" font-size="12" fill="${h.color}" font-weight="600" paint-order="stroke" stroke="#fff" stroke-width="3">${esc(h.label)}</text>`);
      }
    }
    // vertical marks: a dashed line (the change's start) or a flag at the top (an event)
    for (const vl of o.vlines || []) {
      if (!fin(vl.x) || vl.x < x0 || vl.x > x1) continue;
      const x = sx(vl.x).toFixed(1);
      if (vl.flag) {
        parts.push(`<path d="M${x} ${m.t + 9} l-5 -9 h10 z" fill="${vl.color}" stroke="#fff" stroke-width="1"><title>${esc(vl.title || '')}</title></path>`);
      } else {
        parts.push(`<line x1="${x}" x2="${x}" y1="${m.t}" y2="${m.t + ph}" stroke="${vl.color}" stroke-width="1.5" stroke-dasharray="${vl.dash || ''}"><title>${esc(vl.title || '')}</title></line>`);
      }
    }
    // series
    parts.push(`<g clip-path="url(#${o.id}-clip)">`);
    const gap = o.gapS || Infinity;
    const marks = [];
    (o.series || []).forEach((s, si) => {
      const pts = thin(s.points.filter((p) => fin(p[0]) && fin(p[1])), sx, gap);
      const segs = [];
      let cur = [];
      for (const p of pts) {
        if (p === null) { if (cur.length) segs.push(cur); cur = []; continue; }
        cur.push(`${sx(p[0]).toFixed(1)},${clampY(sy(p[1])).toFixed(1)}`);
      }
      if (cur.length) segs.push(cur);
      for (const seg of segs) {
        if (seg.length === 1) {
          const [x, y] = seg[0].split(',');
          parts.push(`<circle cx="${x}" cy="${y}" r="1.8" fill="${s.color}"/>`);
        } else {
          parts.push(`<polyline fill="none" stroke="${s.color}" stroke-width="${s.width || 1.5}" stroke-linejoin="round" stroke-dasharray="${s.dash || ''}" points="${seg.join(' ')}"/>`);
        }
      }
      // markers every ~70 px, offset per series so that coinciding lines all show theirs
      if (s.marker) {
        const real = pts.filter((p) => p !== null);
        const every = 70;
        let next = m.l + 12 + (si * 17) % every;
        for (const p of real) {
          const x = sx(p[0]);
          if (x >= next) {
            marks.push(marker(s.marker, x, clampY(sy(p[1])), s.color));
            next = x + every;
          }
        }
      }
    });
    parts.push(...marks);
    parts.push('</g></svg>');
    return parts.join('');
  }

  function marker(kind, x, y, color) {
    const X = x.toFixed(1);
    const Y = y.toFixed(1);
    if (kind === 'square') return `<rect x="${(x - 3.5).toFixed(1)}" y="${(y - 3.5).toFixed(1)}" width="7" height="7" fill="#fff" stroke="${color}" stroke-width="1.6"/>`;
    if (kind === 'triangle') return `<path d="M${X} ${(y - 4.5).toFixed(1)} L${(x + 4.2).toFixed(1)} ${(y + 3.2).toFixed(1)} L${(x - 4.2).toFixed(1)} ${(y + 3.2).toFixed(1)} Z" fill="#fff" stroke="${color}" stroke-width="1.6"/>`;
    if (kind === 'diamond') return `<path d="M${X} ${(y - 4.5).toFixed(1)} L${(x + 4.5).toFixed(1)} ${Y} L${X} ${(y + 4.5).toFixed(1)} L${(x - 4.5).toFixed(1)} ${Y} Z" fill="#fff" stroke="${color}" stroke-width="1.6"/>`;
    return `<circle cx="${X}" cy="${Y}" r="3.8" fill="#fff" stroke="${color}" stroke-width="1.6"/>`;
  }

  /** Min and max of each pixel column, in time order; null marks a gap. */
  function thin(points, sx, gapS) {
    const out = [];
    let col = null;
    let lo = null;
    let hi = null;
    let lastX = -Infinity;
    const flush = () => {
      if (!lo) return;
      if (lo === hi) out.push(lo);
      else if (lo[0] <= hi[0]) out.push(lo, hi);
      else out.push(hi, lo);
    };
    for (const p of points) {
      if (p[0] - lastX > gapS && out.length + (lo ? 1 : 0) > 0) {
        flush(); lo = hi = null; col = null; out.push(null);
      }
      lastX = p[0];
      const c = Math.floor(sx(p[0]));
      if (c !== col) { flush(); col = c; lo = p; hi = p; continue; }
      if (p[1] < lo[1]) lo = p;
      if (p[1] > hi[1]) hi = p;
    }
    flush();
    return out;
  }

  function legendItem(label, color, dash, mk, width = 2) {
    const mkSvg = mk ? marker(mk, 14, 7, color) : '';
    return `<li><svg width="28" height="14" aria-hidden="true"><line x1="1" x2="27" y1="7" y2="7" stroke="${color}" stroke-width="${width}" stroke-dasharray="${dash || ''}"/>${mkSvg}</svg>${esc(label)}</li>`;
  }

  /** Contiguous spans of advisory and alarm from the trip rows' level column. */
  function levelBands(rows) {
    const bands = [];
    let cur = null;
    for (const r of rows) {
      const lv = r.level;
      const t0 = fin(r.start) ? r.start : r.end;
      const t1 = fin(r.end) ? r.end : r.start;
      if (lv === 'advisory' || lv === 'alarm') {
        if (cur && cur.lv === lv) cur.x1 = t1;
        else { if (cur) bands.push(cur); cur = { lv, x0: t0, x1: t1 }; }
      } else if (cur) { cur.x1 = t0; bands.push(cur); cur = null; }
    }
    if (cur) bands.push(cur);
    return bands.map((b) => ({ x0: b.x0, x1: b.x1, fill: b.lv === 'alarm' ? '#fbd9d5' : '#fdefd0' }));
  }

  const rowTime = (r) => (fin(r.end) ? r.end : r.start);

  /** Least and greatest of many numbers (no spread: a long history would overflow the stack). */
  function extent(xs) {
    let lo = Infinity;
    let hi = -Infinity;
    for (const x of xs) {
      if (x < lo) lo = x;
      if (x > hi) hi = x;
    }
    return [lo, hi];
  }

  function riskChart(rows, v, width, clock, id, events) {
    const xs = rows.map(rowTime).filter(fin);
    if (!v && !xs.length) return '<p class="muted">Not monitored: without an active model no risk is computed.</p>';
    if (xs.length < 2) return `<p class="muted">${xs.length ? 'One trip' : 'No trip'} monitored yet: the chart starts at the second.</p>`;
    const [x0, x1] = extent(xs);
    const adv = v && Array.isArray(v.risk) ? v.risk[1] : NaN;
    const alm = v && Array.isArray(v.risk) ? v.risk[2] : NaN;
    const keys = ['risk', 'risk_motor', 'risk_brake', 'risk_friction'];
    const vals = [];
    for (const r of rows) for (const k of keys) if (fin(r[k])) vals.push(r[k]);
    vals.sort((a, b) => a - b);
    const top = Math.max(quantile(vals, 0.995) || 0, fin(alm) ? alm : 0, fin(adv) ? adv : 0) * 1.15 || 1;
    const yLog = fin(adv) && fin(alm) && adv > 0 && alm / adv > 50;
    const y0 = yLog ? Math.max(adv / 100, 1e-6) : 0;
    const series = [
      { label: 'R_motor (drive)', key: 'risk_motor', color: MODE_COLOR.motor, dash: '7 4', marker: 'circle', width: 1.6 },
      { label: 'R_brake', key: 'risk_brake', color: MODE_COLOR.brake, dash: '2 3', marker: 'square', width: 1.8 },
      { label: 'R_friction (guide rails)', key: 'risk_friction', color: MODE_COLOR.friction, dash: '10 3 2 3', marker: 'triangle', width: 1.6 },
      { label: 'R combined', key: 'risk', color: '#111827', dash: '', marker: null, width: 2.4 },
    ].map((s) => ({ ...s, points: rows.map((r) => [rowTime(r), r[s.key]]) }));
    const hlines = [];
    if (fin(adv)) hlines.push({ y: adv, label: `advisory ${sig(adv)}`, color: '#8a5000', dash: '8 4' });
    if (fin(alm)) hlines.push({ y: alm, label: `alarm ${sig(alm)}`, color: '#b3261e', dash: '3 3' });
    const LEVEL_COLOR = { alarm: '#b3261e', advisory: '#8a5000', normal: '#1e6b34' };
    const vlines = (events || []).map((e) => ({
      x: e.time, flag: true, color: LEVEL_COLOR[e.level] || '#4b5563',
      title: `${e.level} (${modeText(e.mode, e.channel)}) ${instantText(e.time, clock)}`,
    }));
    if (v && fin(v.since) && v.level !== 'normal') {
      vlines.push({ x: v.since, color: '#374151', dash: '2 4', title: `the change began ${instantText(v.since, clock)}` });
    }
    const svg = lineChart({
      id, width, height: 280, x0, x1, clock, yLog, y0, y1: top, yTitle: yLog ? 'risk (log scale)' : 'risk',
      series, hlines, vlines, bands: levelBands(rows), gapS: 2 * DAY,
      aria: 'risk over time: combined R, per-mode risks, advisory and alarm levels',
    });
    const legend = '<ul class="legend">' +
      series.slice().reverse().map((s) => legendItem(s.label, s.color, s.dash, s.marker, s.width)).join('') +
      legendItem('advisory level', '#8a5000', '8 4') + legendItem('alarm level', '#b3261e', '3 3') +
      '<li><svg width="18" height="12" aria-hidden="true"><rect width="18" height="12" fill="#fdefd0"/></svg>advisory</li>' +
      '<li><svg width="18" height="12" aria-hidden="true"><rect width="18" height="12" fill="#fbd9d5"/></svg>alarm</li>' +
      '<li><svg width="14" height="12" aria-hidden="true"><path d="M7 11 l-6 -10 h12 z" fill="#8a5000"/></svg>event (level change)</li>' +
      legendItem('the change began', '#374151', '2 4') + '</ul>';
    return svg + legend;
  }

  const DRIFT_PANELS = [
    { key: 'kd_drift_pct', mode: 'motor', title: 'Kd (drive)', unit: '%' },
    { key: 'friction_drift_pct', mode: 'friction', title: 'friction (guide rails)', unit: '%' },
    { key: 'brake_drag_n', mode: 'brake', title: 'brake drag', unit: 'N' },
  ];

  function driftCharts(rows, v, width, clock, id) {
    const xs = rows.map(rowTime).filter(fin);
    if (!v && !xs.length) return '<p class="muted">Not monitored: without an active model no drift is estimated.</p>';
    if (xs.length < 2) return `<p class="muted">${xs.length ? 'One trip' : 'No trip'} monitored yet: the chart starts at the second.</p>`;
    const [x0, x1] = extent(xs);
    const narrow = width < 700;
    const pwid = narrow ? width : (width - 32) / 3;
    return '<div class="panels">' + DRIFT_PANELS.map((p, i) => {
      const pts = rows.map((r) => [rowTime(r), r[p.key]]);
      const vals = pts.map((q) => q[1]).filter(fin).sort((a, b) => a - b);
      const fcMode = v && v.forecast && Array.isArray(v.forecast.modes) ? v.forecast.modes.find((f) => f.mode === p.mode) : null;
      const th = (name) => {
        const c = fcMode && (fcMode.crossings || []).find((x) => x.name === name);
        return c && fin(c.threshold) ? c.threshold : NaN;
      };
      const adv = th('advisory level');
      const alm = th('alarm level');
      const lim = th('physical limit');
      let lo = vals.length ? quantile(vals, 0.01) : -1;
      let hi = vals.length ? quantile(vals, 0.99) : 1;
      lo = Math.min(lo, 0);
      hi = Math.max(hi, 0, fin(adv) ? adv : -Infinity);
      if (fin(alm) && alm < hi * 3) hi = Math.max(hi, alm);
      if (fin(lim) && lim < hi * 3) hi = Math.max(hi, lim);
      const pad2 = (hi - lo) * 0.1 || 1;
      const now = v && Array.isArray(v.drifts) ? v.drifts.find((d) => d.mode === p.mode) : null;
      const hl = [{ y: 0, label: '', color: '#8b95a1', dash: '' }];
      if (fin(adv)) hl.push({ y: adv, label: `advisory ${signed(adv, p.unit === 'N' ? 0 : 1)} ${p.unit}`, color: '#8a5000', dash: '8 4' });
      if (fin(alm)) hl.push({ y: alm, label: `alarm ${signed(alm, p.unit === 'N' ? 0 : 1)} ${p.unit}`, color: '#b3261e', dash: '3 3' });
      if (fin(lim)) hl.push({ y: lim, label: `physical limit ${signed(lim, p.unit === 'N' ? 0 : 1)} ${p.unit}`, color: '#374151', dash: '10 3 2 3' });
      const svg = vals.length ? lineChart({
        id: `${id}-${i}`, width: pwid, height: 200, x0, x1, clock, yLog: false,
        y0: lo - pad2, y1: hi + pad2, yTitle: p.unit === 'N' ? 'N' : '%',
        series: [{ label: p.title, color: MODE_COLOR[p.mode], width: 1.6, points: pts }],
        hlines: hl, gapS: 2 * DAY, aria: `${p.title} drift over time`,
      }) : '<p class="muted small">no value yet (the regression is not determined)</p>';
      return `<div><h3>${esc(p.title)} <span class="small muted">now ${esc(now ? driftText(now).replace(now.quantity + ' ', '') : 'n/a')}</span></h3>${svg}</div>`;
    }).join('') + '</div>';
  }

  function tripsPerDayChart(rows, width, clock) {
    const off = clock.off;
    const counts = new Map();
    for (const r of rows) {
      const t = fin(r.start) ? r.start : r.end;
      if (!fin(t)) continue;
      const d = Math.floor((t + (isCal(t) ? off : 0)) / DAY);
      counts.set(d, (counts.get(d) || 0) + 1);
    }
    if (counts.size < 1) return '';
    const days = [...counts.keys()].sort((a, b) => a - b);
    const d0 = days[0];
    const d1 = days[days.length - 1];
    const n = d1 - d0 + 1;
    if (n > 400) return '';
    const W = Math.max(240, width);
    const H = 150;
    const m = { l: 44, r: 8, t: 8, b: 34 };
    const pw = W - m.l - m.r;
    const ph = H - m.t - m.b;
    const max = Math.max(...counts.values());
    const st = niceStep(max, 3);
    const top = Math.ceil(max / st) * st || 1;
    const bw = pw / n;
    const out = [`<svg class="chart" width="${W}" height="${H}" viewBox="0 0 ${W} ${H}" role="img" aria-label="trips per day">`];
    for (let v = 0; v <= top + 1e-9; v += st) {
      const y = m.t + ph - (v / top) * ph;
      out.push(`<line x1="${m.l}" x2="${m.l + pw}" y1="${y.toFixed(1)}" y2="${y.toFixed(1)}" stroke="#e3e7ec"/>`);
      out.push(`<text x="${m.l - 5}" y="${(y + 4).toFixed(1)}" text-anchor="end" font-size="12">${v}</text>`);
    }
    const cal = isCal(rows.length ? (rows[0].start ?? rows[0].end) : NaN);
    const labelEvery = Math.max(1, Math.ceil(n / Math.max(1, Math.floor(pw / 48))));
    for (let i = 0; i < n; i++) {
      const c = counts.get(d0 + i) || 0;
      const h = (c / top) * ph;
      const x = m.l + i * bw;
      out.push(`<rect x="${(x + bw * 0.12).toFixed(1)}" y="${(m.t + ph - h).toFixed(1)}" width="${Math.max(1, bw * 0.76).toFixed(1)}" height="${h.toFixed(1)}" fill="#5b7fa8"><title>${c} trips</title></rect>`);
      if (i % labelEvery === 0) {
        let lab;
        if (cal) { const d = new Date((d0 + i) * DAY * 1000); lab = `${d.getUTCDate()} ${MONTHS[d.getUTCMonth()]}`; } else lab = `${d0 + i}`;
        out.push(`<text x="${(x + bw / 2).toFixed(1)}" y="${m.t + ph + 16}" text-anchor="middle" font-size="12">${lab}</text>`);
      }
    }
    out.push(`<text x="${m.l + pw / 2}" y="${H - 3}" text-anchor="middle" font-size="12" fill="#5b6470">${cal ? `day (${zoneName(off)}); the first and last may be partial` : 'day of data; the first and last may be partial'}</text>`);
    out.push('</svg>');
    return out.join('');
  }

  // ---------------------------------------------------------------- elevator page

  function paramRows(params) {
    if (!params) return [];
    if (Array.isArray(params)) {
      return params.map((p) => ({
        name: p.name, value: p.value, se: p.std_error ?? p.se, unit: p.unit,
        note: p.determined === false ? 'not determined by the data (its prior)' : '',
      }));
    }
    return Object.entries(params).map(([name, p]) => {
      if (p && typeof p === 'object') {
        return { name, value: p.value, se: p.std_error ?? p.se, unit: p.unit, note: p.determined === false ? 'not determined by the data (its prior)' : '' };
      }
      return { name, value: p, se: null, unit: '', note: '' };
    });
  }

  function paramTable(params) {
    const rows = paramRows(params);
    if (!rows.length) return '<p class="muted">No parameters stated.</p>';
    return '<div class="table-wrap"><table class="data compact"><thead><tr><th>parameter</th><th>value</th><th>\u00b1 SE</th><th>unit</th></tr></thead><tbody>' +
      rows.map((r) => `<tr><td><code>${esc(r.name)}</code>${r.note ? `<br><span class="small muted">${esc(r.note)}</span>` : ''}</td>` +
        `<td class="num">${esc(typeof r.value === 'number' ? sig(r.value) : String(r.value ?? 'n/a'))}</td>` +
        `<td class="num">${esc(fin(r.se) ? sig(r.se) : '')}</td><td class="nowrap">${esc(r.unit || '')}</td></tr>`).join('') +
      '</tbody></table></div>';
  }

  function eventsTable(events, clock, monitored) {
    if (!events.length) {
      return monitored ? '<p class="muted">No events: the level has not changed since monitoring began.</p>'
        : '<p class="muted">No events: not monitored yet (no active model).</p>';
    }
    const sorted = events.slice().sort((a, b) => (b.time ?? 0) - (a.time ?? 0));
    const known = new Set(['elevator', 'id', 'seq', 'time', 'time_text', 'level', 'mode', 'channel', 'risk', 'label',
      'risk_motor', 'risk_brake', 'risk_friction', 'kd_drift_pct', 'kd_drift_se_pct', 'friction_drift_pct',
      'friction_drift_se_pct', 'brake_drag_n', 'brake_drag_se_n', 'trips', 'implausible_trips',
      'cusum_ratio', 'cusum_signature', 'cusum_size', 'cusum_trips']);
    const evidence = (e) => {
      const out = [];
      const d = (q, v, se, unit) => {
        if (fin(v)) out.push(driftText({ quantity: q, value: v, se, unit }));
      };
      d('Kd', e.kd_drift_pct, e.kd_drift_se_pct, '%');
      d('friction', e.friction_drift_pct, e.friction_drift_se_pct, '%');
      d('brake drag', e.brake_drag_n, e.brake_drag_se_n, 'N');
      if (fin(e.cusum_ratio)) out.push(`G/h ${e.cusum_ratio.toFixed(2)}${fin(e.cusum_trips) ? ` over ${e.cusum_trips} trips` : ''}${e.cusum_signature ? ` (${e.cusum_signature})` : ''}`);
      for (const [k, val] of Object.entries(e)) {
        if (!known.has(k) && val !== null && typeof val !== 'object') out.push(`${k} ${typeof val === 'number' ? sig(val) : val}`);
      }
      return out.join('; ');
    };
    return '<div class="table-wrap"><table class="data"><thead><tr><th>when</th><th>level</th><th>mode</th><th>risk R</th><th>evidence</th><th>label</th></tr></thead><tbody>' +
      sorted.map((e) => {
        const ev = evidence(e);
        const label = e.label === 'confirmed' ? '<span class="label-confirmed">confirmed</span>'
          : e.label === 'not_found' ? '<span class="label-not_found">not found</span>' : '<span class="muted">open</span>';
        return `<tr><td class="nowrap">${esc(whenText(e.time, e.time_text, clock))}</td><td>${badge(e.level || 'none')}</td>` +
          `<td>${esc(modeText(e.mode, e.channel))}</td><td class="num">${esc(sig(e.risk))}</td>` +
          `<td class="small">${esc(ev)}</td><td>${label}</td></tr>`;
      }).join('') + '</tbody></table></div>';
  }

  function changesText(ch) {
    if (!ch || typeof ch !== 'object') return '';
    const items = Object.entries(ch).filter(([, v]) => fin(v)).sort((a, b) => Math.abs(b[1]) - Math.abs(a[1]));
    return items.slice(0, 6).map(([k, v]) => `${k} ${signed(v, 1)} %`).join(', ') + (items.length > 6 ? ', \u2026' : '');
  }

  function modelsTable(models, clock) {
    if (!models.length) return '<p class="muted">No model versions yet.</p>';
    return '<div class="table-wrap"><table class="data"><thead><tr><th>version</th><th>created</th><th>source</th><th>note</th><th>status</th><th>change vs active</th></tr></thead><tbody>' +
      models.slice().sort((a, b) => (b.version ?? 0) - (a.version ?? 0)).map((mv) =>
        `<tr${mv.active ? ' class="this"' : ''}><td class="num">v${esc(mv.version)}${mv.active ? ' <span class="pill">active</span>' : ''}</td>` +
        `<td class="nowrap">${esc(createdText(mv, clock))}</td><td>${esc(mv.source || '')}</td><td>${esc(mv.note || '')}</td>` +
        `<td>${esc(mv.status || (mv.active ? 'active' : ''))}</td>` +
        `<td class="small">${esc(mv.active ? '' : changesText(mv.changes))}</td></tr>`).join('') + '</tbody></table></div>';
  }

  function createdText(mv, clock) {
    if (typeof mv.created_text === 'string') return rfcText(mv.created_text);
    if (typeof mv.created === 'string') return rfcText(mv.created);
    if (fin(mv.created)) return instantText(mv.created, { off: clock.off });
    return '';
  }

  function visitsTable(visits, clock, id) {
    if (!visits.length) return `<p class="muted">No maintenance visits recorded. Record one with <code>POST /api/v1/elevators/${esc(id)}/maintenance</code>: it labels the open events and can start a re-baseline.</p>`;
    return '<div class="table-wrap"><table class="data"><thead><tr><th>when</th><th>work</th><th>finding</th><th>re-baseline</th><th>events labelled</th></tr></thead><tbody>' +
      visits.slice().sort((a, b) => (b.time ?? 0) - (a.time ?? 0)).map((x) =>
        `<tr><td class="nowrap">${esc(whenText(x.time, x.time_text, clock))}</td><td>${esc(x.work || '')}</td>` +
        `<td>${x.finding === 'confirmed' ? '<span class="label-confirmed">confirmed</span>' : x.finding === 'not_found' ? '<span class="label-not_found">not found</span>' : esc(x.finding || '')}</td>` +
        `<td>${x.rebaseline ? 'yes' : 'no'}</td><td class="num">${fin(x.labelled_events) ? x.labelled_events : ''}</td></tr>`).join('') + '</tbody></table></div>';
  }

  function peersOf(me, fleet) {
    const same = (a, b) => a !== null && a !== undefined && a === b;
    let basis;
    let peers;
    if (me.group) {
      peers = fleet.filter((s) => s.id !== me.id && s.group === me.group);
      basis = `the same group (${me.group})`;
    }
    if (!peers || !peers.length) {
      const rated = fleet.filter((s) => s.id !== me.id && same(s.rated_load_kg, me.rated_load_kg) &&
        same(s.rated_speed_mps, me.rated_speed_mps) && same(s.floors, me.floors));
      if (rated.length || !peers) {
        peers = rated;
        basis = `the same rated load, speed and floors (${num(me.rated_load_kg, 0)} kg, ${num(me.rated_speed_mps, 2)} m/s, ${me.floors ?? '?'} floors)`;
      }
    }
    return { peers, basis };
  }

  const driftOf = (s, mode) => (s.verdict && Array.isArray(s.verdict.drifts) ? s.verdict.drifts.find((d) => d.mode === mode) : null);

  function median(xs) {
    const a = xs.filter(fin).sort((p, q) => p - q);
    if (!a.length) return NaN;
    const h = a.length >> 1;
    return a.length % 2 ? a[h] : (a[h - 1] + a[h]) / 2;
  }

  /**
   * One drift across the peers: a row per elevator, its value as a point with ± one SE, this
   * car first and filled; zero and this car's advisory level (in the same unit) as lines.
   */
  function peerStrip(all, me, p, width) {
    const items = all.map((s) => ({ s, d: driftOf(s, p.mode) })).filter((x) => x.d && fin(x.d.value));
    if (!items.length) return '';
    const rowH = 22;
    const W = Math.max(200, Math.round(width));
    const m = { l: Math.round(Math.min(150, W * 0.38)), r: 12, t: 6, b: 30 };
    const maxChars = Math.floor((m.l - 10) / 7);
    const clip = (t) => (t.length > maxChars ? `${t.slice(0, Math.max(1, maxChars - 1))}\u2026` : t);
    const H = m.t + m.b + rowH * items.length;
    const fc = me.verdict && me.verdict.forecast && Array.isArray(me.verdict.forecast.modes)
      ? me.verdict.forecast.modes.find((f) => f.mode === p.mode) : null;
    const advC = fc && (fc.crossings || []).find((c) => c.name === 'advisory level');
    const adv = advC && fin(advC.threshold) ? advC.threshold : NaN;
    let lo = 0;
    let hi = 0;
    for (const { d } of items) {
      const se = fin(d.se) ? d.se : 0;
      lo = Math.min(lo, d.value - se);
      hi = Math.max(hi, d.value + se);
    }
    if (fin(adv)) hi = Math.max(hi, adv);
    const padX = (hi - lo) * 0.08 || 1;
    lo -= padX;
    hi += padX;
    const pw = W - m.l - m.r;
    const sx = (x) => m.l + ((x - lo) / (hi - lo)) * pw;
    const out = [`<svg class="chart" width="${W}" height="${H}" viewBox="0 0 ${W} ${H}" role="img" aria-label="${esc(p.title)} of this car and its peers">`];
    const st = niceStep(hi - lo, Math.max(2, Math.floor(pw / 70)));
    const dec = Math.max(0, -Math.floor(Math.log10(st) + 1e-9));
    for (let v = Math.ceil(lo / st) * st; v <= hi; v += st) {
      const x = sx(v).toFixed(1);
      out.push(`<line x1="${x}" x2="${x}" y1="${m.t}" y2="${H - m.b}" stroke="#e3e7ec"/>`);
      out.push(`<text x="${x}" y="${H - m.b + 15}" text-anchor="middle" font-size="12">${esc((Math.abs(v) < st / 1e6 ? 0 : v).toFixed(dec).replace('-', '\u2212'))}</text>`);
    }
    out.push(`<text x="${m.l + pw / 2}" y="${H - 3}" text-anchor="middle" font-size="12" fill="#5b6470">${esc(p.title)} drift (${p.unit}) \u00b1 one SE</text>`);
    out.push(`<line x1="${sx(0).toFixed(1)}" x2="${sx(0).toFixed(1)}" y1="${m.t}" y2="${H - m.b}" stroke="#8b95a1"/>`);
    if (fin(adv)) {
      const x = sx(adv).toFixed(1);
      out.push(`<line x1="${x}" x2="${x}" y1="${m.t}" y2="${H - m.b}" stroke="#8a5000" stroke-width="1.5" stroke-dasharray="8 4"><title>advisory level of this car</title></line>`);
    }
    items.forEach(({ s, d }, i) => {
      const y = m.t + rowH * i + rowH / 2;
      const mine = s.id === me.id;
      const color = mine ? MODE_COLOR[p.mode] : '#4b5563';
      const se = fin(d.se) ? d.se : 0;
      out.push(`<line x1="${sx(d.value - se).toFixed(1)}" x2="${sx(d.value + se).toFixed(1)}" y1="${y}" y2="${y}" stroke="${color}" stroke-width="${mine ? 2.5 : 1.5}"/>`);
      out.push(`<circle cx="${sx(d.value).toFixed(1)}" cy="${y}" r="${mine ? 5 : 4}" fill="${mine ? color : '#fff'}" stroke="${color}" stroke-width="1.6"><title>${esc(displayName(s))}: ${esc(driftText(d))}</title></circle>`);
      out.push(`<text x="${m.l - 8}" y="${y + 4}" font-size="12" text-anchor="end"${mine ? ' font-weight="700"' : ''}>${esc(clip(displayName(s)))}<title>${esc(displayName(s))}</title></text>`);
    });
    out.push('</svg>');
    return out.join('');
  }

  function peersSection(me, fleet, width) {
    if (!fleet) return '<p class="muted">The fleet could not be loaded for the comparison.</p>';
    const { peers, basis } = peersOf(me, fleet);
    if (!peers.length) return `<p class="muted">No peers: no other elevator has ${esc(basis)}.</p>`;
    const all = [me, ...sortFleet(peers)];
    const cell = (s, mode) => { const d = driftOf(s, mode); return d ? driftText(d).replace(`${d.quantity} `, '') : 'n/a'; };
    const lines = [];
    for (const p of DRIFT_PANELS) {
      const mine = driftOf(me, p.mode);
      const med = median(peers.map((s) => { const d = driftOf(s, p.mode); return d ? d.value : NaN; }));
      if (mine && fin(mine.value) && fin(med)) {
        const k = driftDecimals(p.unit);
        lines.push(`${p.title}: this car ${signed(mine.value, k)} ${p.unit}, the peers\u2019 median ${signed(med, k)} ${p.unit}`);
      }
    }
    const shown = all.slice(0, 12);
    const narrow = width < 700;
    const sw = narrow ? width : (width - 32) / 3;
    const withValues = (p) => shown.filter((x) => { const d = driftOf(x, p.mode); return d && fin(d.value); }).length;
    const strips = DRIFT_PANELS.filter((p) => withValues(p) >= 2).map((p) => peerStrip(shown, me, p, sw)).filter(Boolean);
    return `<p>Compared with ${peers.length} elevator${peers.length > 1 ? 's' : ''} of ${esc(basis)}.` +
      (lines.length ? ` ${esc(lines.join('; '))}.` : '') + '</p>' +
      (strips.length ? `<div class="panels">${strips.map((x) => `<div>${x}</div>`).join('')}</div>` +
        `<p class="chart-note">Filled and first: this car; dashed: this car\u2019s advisory level for the drift${all.length > 12 ? '; the 11 peers at highest risk shown' : ''}.</p>` : '') +
      '<div class="table-wrap"><table class="data"><thead><tr><th>elevator</th><th>level</th><th>mode</th><th>Kd</th><th>friction</th><th>brake drag</th><th>R / advisory</th><th>trips/day</th><th>last data</th></tr></thead><tbody>' +
      all.map((s) => {
        const v = s.verdict;
        const rr = riskRatio(v);
        return `<tr${s.id === me.id ? ' class="this"' : ''}><td><a href="${elevatorHref(s.id)}">${esc(displayName(s))}</a>${s.id === me.id ? ' (this one)' : ''}</td>` +
          `<td>${badge(levelOf(s), s)}</td><td>${esc(v && v.level !== 'normal' ? modeText(v.mode, v.channel) : '\u2014')}</td>` +
          `<td class="num">${esc(cell(s, 'motor'))}</td><td class="num">${esc(cell(s, 'friction'))}</td><td class="num">${esc(cell(s, 'brake'))}</td>` +
          `<td class="num">${rr === null ? 'n/a' : esc(sig(rr))}</td><td class="num">${esc(num(s.trips_per_day, 0))}</td>` +
          `<td class="small">lag ${esc(durationText(s.lag_s))}</td></tr>`;
      }).join('') + '</tbody></table></div>';
  }

  function verdictSection(s) {
    const v = s.verdict;
    const clock = clockOf(s);
    if (!v && waiting(s)) {
      return `<section class="card verdict lv-none" id="verdict"><h2>Verdict ${badge('none', s)}</h2>` +
        `<p class="headline">Model v${esc(s.model_version)} is active; no verdict yet: the monitor has not watched a sample of this elevator.</p>` +
        `<p>Stream its telemetry (<code>liftwatch replay --input RAW.csv --id ${esc(s.id)} --to ${esc(location.origin)}</code> or <code>POST /api/v1/elevators/${esc(s.id)}/telemetry</code>).</p></section>`;
    }
    if (!v) {
      return `<section class="card verdict lv-none" id="verdict"><h2>Verdict ${badge('none')}</h2>` +
        '<p class="headline">No active model yet: this elevator is stored but not monitored.</p>' +
        `<p>Fit one from a healthy week (<code>liftwatch fit --input RAW.csv --elevator elevator.toml --out model.json</code>) and upload it with <code>POST /api/v1/elevators/${esc(s.id)}/models</code>, or fit from the stored history with <code>POST /api/v1/elevators/${esc(s.id)}/fit</code>.</p></section>`;
    }
    const lv = v.level;
    const asOf = fin(v.time) ? ` (as of ${instantText(v.time, clock)})` : ' (no data watched yet)';
    const hd = headlineDrift(v);
    let headline;
    if (lv === 'normal' && fin(v.cusum_ratio) && v.cusum_ratio >= 1) {
      // As `status` says it: a crossing held back because no signature explains it yet.
      headline = `NORMAL${asOf}, watching: a change the fault signatures cannot yet tell apart (G/h ${v.cusum_ratio.toFixed(2)}; drifts ${(v.drifts || []).map(driftText).join(', ')}); it becomes an advisory once it names its mode, triples, or has stood a day; ${v.inspect}.`;
    } else if (lv === 'normal') {
      headline = `NORMAL${asOf}: consistent with the healthy reference (drifts ${(v.drifts || []).map(driftText).join(', ')}); ${v.inspect}.`;
    } else {
      const since = fin(v.since) ? ` since ${dayText(v.since, clock)}` : '';
      // As `status` says it: a sensor verdict that names its channel says which sensor, without
      // the machine's drifts (they stay in the Drifts row below) and the machine's `since`.
      const named = v.mode === 'sensor' && v.channel;
      const what = named ? `the ${channelWords(v.channel)} (${v.channel} channel)`
        : hd && hd.own ? driftText(hd.drift) : `drifts ${(v.drifts || []).map(driftText).join(', ')}`;
      headline = `${lv.toUpperCase()}${asOf}, ${SUBSYSTEM[v.mode] || v.mode}: ${what}${named ? '' : since}; ${v.inspect}.`;
    }
    const caveats = Array.isArray(v.caveats) && v.caveats.length ? v.caveats.join('; ') : 'none from the model.';
    return `<section class="card verdict lv-${esc(lv)}" id="verdict"><h2>Verdict ${badge(lv)}</h2>` +
      `<p class="headline">${esc(headline)}</p><dl>` +
      `<dt>Level</dt><dd>${esc(lv)}${fin(v.since) && lv !== 'normal' ? `, the change began ${esc(dayText(v.since, clock))}` : ''}</dd>` +
      `<dt>Mode</dt><dd>${esc(lv === 'normal' ? 'none (normal)' : (SUBSYSTEM[v.mode] && SUBSYSTEM[v.mode] !== v.mode ? `${v.mode} (${SUBSYSTEM[v.mode]})` : v.mode) + (lv !== 'normal' && v.mode === 'sensor' && v.channel ? `, the ${v.channel} channel` : ''))}</dd>` +
      `<dt>Drifts</dt><dd>${esc((v.drifts || []).map(driftText).join('; '))}</dd>` +
      `<dt>Inspect</dt><dd>${esc(v.inspect)}</dd>` +
      `<dt>Forecast</dt><dd>${esc(forecastSentence(v, clock))}</dd>` +
      `<dt>Evidence</dt><dd>${esc(evidenceSentence(v))}</dd>` +
      `<dt>Caveats</dt><dd>${esc(caveats)}</dd></dl></section>`;
  }

  function elevatorPage(id) {
    $app.innerHTML = `<p class="crumbs"><a href="#/">\u2190 Fleet</a></p><div id="ev-head"><h1>${esc(id)}</h1></div>` +
      '<div id="ev-verdict"></div>' +
      '<section class="card"><h2>Risk over time</h2><div id="ev-risk"><p class="muted">Loading\u2026</p></div>' +
      `<p class="chart-note">One point per trip, the last ${RISK_WINDOW_DAYS} days at most.` + ' Combined R solid; per-mode risks dashed with markers (they can coincide); shaded spans: the level at each trip (the sequential test can raise it before R reaches its line); flags: the events; dotted: where the change began.</p></section>' +
      '<section class="card"><h2>Drift in physical units</h2><div id="ev-drift"></div>' +
      '<p class="chart-note">Per trip, as the monitor re-identifies it; dashed lines: the drift that, held, brings the mode\u2019s risk to its level; dash-dot: the physical limit.</p></section>' +
      '<section class="card"><h2>Peers</h2><div id="ev-peers"></div></section>' +
      '<section class="card"><h2>Events</h2><div id="ev-events"></div></section>' +
      '<div class="grid2"><section class="card"><h2>Usage</h2><div id="ev-usage"></div></section>' +
      '<section class="card"><h2>Maintenance visits</h2><div id="ev-visits"></div></section></div>' +
      '<div class="grid2"><section class="card"><h2>Model</h2><div id="ev-model"></div></section>' +
      '<section class="card"><h2>Model versions</h2><div id="ev-models"></div></section></div>';
    const el = (k) => document.getElementById(`ev-${k}`);
    const enc = encodeURIComponent(id);
    let rows = [];
    let summary = null;
    let fleetList = null;
    let eventList = [];
    let first = true;

    function drawCharts() {
      if (!summary) return;
      const clock = clockOf(summary);
      const w = el('risk').clientWidth || 900;
      put(el('risk'), riskChart(rows, summary.verdict, w, clock, 'risk', eventList));
      put(el('drift'), driftCharts(rows, summary.verdict, el('drift').clientWidth || 900, clock, 'drift'));
      put(el('peers'), peersSection(summary, fleetList, el('peers').clientWidth || 900));
      const usage = el('usage');
      const base = !fin(summary.trips_per_day) && !fin(summary.door_cycles_per_day) ? '<p class="muted">No usage yet: no trips stored.</p>' : `<p><b class="num">${esc(num(summary.trips_per_day, 0))}</b> trips/day \u00b7 <b class="num">${esc(num(summary.door_cycles_per_day, 0))}</b> door cycles/day</p>` +
        `<p class="small muted">${esc(summary.trips ?? 'n/a')} trips and ${esc(summary.samples ?? 'n/a')} samples stored; last data ${esc(whenText(summary.last_time, summary.last_time_text, clock))} (lag ${esc(durationText(summary.lag_s))}).</p>`;
      put(usage, base + (rows.length ? `<h3>Trips per day</h3>${tripsPerDayChart(rows, (usage.clientWidth || 400), clock)}` : ''));
    }

    /** The trip rows since the last one held (at first the last RISK_WINDOW_DAYS), page by page. */
    async function fetchRows(lastTime) {
      let from = rows.length ? rows[rows.length - 1].start
        : fin(lastTime) ? lastTime - RISK_WINDOW_DAYS * DAY : null;
      for (let page = 0; page < 50; page++) {
        const q = `?limit=${RISK_PAGE}${fin(from) ? `&from=${from}` : ''}`;
        const j = await api(`/elevators/${enc}/risk${q}`);
        const got = Array.isArray(j.rows) ? j.rows : [];
        const last = rows.length ? rows[rows.length - 1].start : -Infinity;
        const fresh = got.filter((r) => fin(r.start) && r.start > last);
        rows = rows.concat(fresh);
        if (got.length < RISK_PAGE || !fresh.length) break;
        from = rows[rows.length - 1].start;
      }
      return rows;
    }

    async function load() {
      const sum = await api(`/elevators/${enc}`).then((value) => ({ status: 'fulfilled', value }),
        (reason) => ({ status: 'rejected', reason }));
      const lastTime = sum.status === 'fulfilled' ? sum.value.last_time : null;
      const [risk, events, models, visits, fleet] = await Promise.allSettled([
        fetchRows(lastTime), api(`/elevators/${enc}/events`), api(`/elevators/${enc}/models`),
        api(`/elevators/${enc}/maintenance`), api('/elevators'),
      ]);
      if (sum.status === 'rejected') {
        setError('summary', sum.reason.message);
        stamp(false);
        if (!summary) {
          put(el('head'), `<h1>${esc(id)}</h1><p>${sum.reason.status === 404 ? 'No elevator with this id.' : 'This elevator could not be loaded (see the error above).'} <a href="#/">Back to the fleet</a>.</p>`);
        }
        return;
      }
      setError('summary', null);
      summary = normalize(sum.value);
      const s = summary;
      const clock = clockOf(s);
      document.title = `${displayName(s)} \u2014 liftwatch`;
      const facts = [
        s.name && s.name !== s.id ? `id <b>${esc(s.id)}</b>` : null,
        s.group ? `group <b>${esc(s.group)}</b>` : null,
        fin(s.rated_load_kg) ? `rated <b>${esc(num(s.rated_load_kg, 0))} kg</b>` : null,
        fin(s.rated_speed_mps) ? `<b>${esc(num(s.rated_speed_mps, 2))} m/s</b>` : null,
        fin(s.floors) ? `<b>${esc(s.floors)}</b> floors` : null,
        `model <b>${s.model_version != null ? `v${esc(s.model_version)}` : 'none'}</b>`,
        `last data <b>${esc(whenText(s.last_time, s.last_time_text, clock))}</b> (lag ${esc(durationText(s.lag_s))})`,
        clock.known ? `times in <b>${esc(zoneName(clock.off))}</b>` : null,
      ].filter(Boolean);
      put(el('head'), `<div class="ev-head"><h1>${esc(displayName(s))}</h1>${badge(levelOf(s), s)}</div><div class="facts">${facts.map((f) => `<span>${f}</span>`).join('')}</div>`);
      put(el('verdict'), verdictSection(s));

      if (risk.status === 'fulfilled') setError('risk', null);
      else setError('risk', risk.reason.message);

      if (events.status === 'fulfilled') { setError('events', null); eventList = events.value.events || []; put(el('events'), eventsTable(eventList, clock, !!s.verdict)); } else { setError('events', events.reason.message); if (first) put(el('events'), '<p class="muted">not available</p>'); }
      put(el('model'), s.model
        ? `<p>Version <b>v${esc(s.model.version)}</b>${s.model.source ? ` from ${esc(s.model.source)}` : ''}${s.model.created != null ? `, created ${esc(createdText(s.model, clock))}` : ''}.` +
          `${s.model.fingerprint ? ` <span class="small muted">fingerprint <code>${esc(String(s.model.fingerprint).slice(0, 16))}</code></span>` : ''}</p>${paramTable(s.model.parameters)}`
        : '<p class="muted">No active model.</p>');
      if (models.status === 'fulfilled') { setError('models', null); put(el('models'), modelsTable(models.value.models || [], clock)); } else { setError('models', models.reason.message); if (first) put(el('models'), '<p class="muted">not available</p>'); }
      if (visits.status === 'fulfilled') { setError('visits', null); put(el('visits'), visitsTable(visits.value.visits || [], clock, s.id)); } else { setError('visits', visits.reason.message); if (first) put(el('visits'), '<p class="muted">not available</p>'); }
      if (fleet.status === 'fulfilled') { setError('peers', null); fleetList = (fleet.value.elevators || []).map(normalize); } else { setError('peers', fleet.reason.message); }
      drawCharts();
      first = false;
      stamp(errors.size === 0);
    }

    const stopPoll = poller(load, ELEVATOR_REFRESH_MS);
    // Charts are drawn at their box's width: redraw when it changes (rotation, window size).
    let drawnAt = 0;
    const ro = typeof ResizeObserver === 'function' ? new ResizeObserver(() => {
      const w = el('risk') ? el('risk').clientWidth : 0;
      if (w && w !== drawnAt) { drawnAt = w; drawCharts(); }
    }) : null;
    if (ro) ro.observe(el('risk'));
    const stop = () => { stopPoll(); if (ro) ro.disconnect(); };
    return { stop, resize: drawCharts };
  }

  route();
})();
