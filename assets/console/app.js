// linterpd's operator console: one page, Preact + htm (vendored, no build step), uPlot.
// Live state comes over one WebSocket (a whole snapshot per robot, then merge patches); every
// command is the daemon's own HTTP API (docs/API.md) behind the console's session.
// Hold-to-run jog: a lease the daemon enforces (docs/CONSOLE.md). This page sends a keep-alive
// every 100 ms while a jog button is held, and a release on pointerup, pointercancel,
// lostpointercapture; "hidden" on blur, visibilitychange and pagehide. The daemon stops the jog
// on any of them, and by itself 300 ms after the last keep-alive: the page is never trusted to
// stop it.
import {
  html, render, useState, useEffect, useRef, useCallback,
} from "/assets/vendor/htm-preact-standalone.module.js";

const KEEP_MS = 100;
const STALE_MS = 2000; // no message for this long: the connection shows red

// RFC 7396 merge patch, as the daemon's console::patch::apply.
function applyPatch(target, patch) {
  if (patch === null || typeof patch !== "object" || Array.isArray(patch)) return patch;
  const out = target && typeof target === "object" && !Array.isArray(target) ? { ...target } : {};
  for (const [k, v] of Object.entries(patch)) {
    if (v === null) delete out[k];
    else out[k] = applyPatch(out[k], v);
  }
  return out;
}

async function call(method, path, body) {
  const init = { method, headers: {}, credentials: "same-origin" };
  if (body !== undefined) {
    init.headers["content-type"] = "application/json";
    init.body = JSON.stringify(body);
  }
  const r = await fetch(path, init);
  let json = null;
  try { json = await r.json(); } catch (_) { /* no body */ }
  if (!r.ok) {
    const why = (json && json.error) || `${r.status} ${r.statusText}`;
    const e = new Error(why);
    e.status = r.status;
    throw e;
  }
  return json;
}

const fmt = (v, d = 3) => (v === null || v === undefined ? "–" : Number(v).toFixed(d));

function Login({ onDone }) {
  const [user, setUser] = useState("");
  const [password, setPassword] = useState("");
  const [error, setError] = useState(null);
  const submit = async (e) => {
    e.preventDefault();
    try {
      onDone(await call("POST", "/console/login", { user, password }));
    } catch (err) { setError(err.message); }
  };
  return html`<form class="login" onSubmit=${submit} data-test-id="login">
    <h1>linterpd console</h1>
    <label>user <input data-test-id="login-user" autocomplete="username"
      value=${user} onInput=${(e) => setUser(e.target.value)} /></label>
    <label>password <input data-test-id="login-password" type="password"
      autocomplete="current-password" value=${password}
      onInput=${(e) => setPassword(e.target.value)} /></label>
    <button type="submit" data-test-id="login-submit">log in</button>
    ${error && html`<p class="error" data-test-id="login-error">${error}</p>`}
    <p class="note">Keep this console on the plant's network, never on the internet.</p>
  </form>`;
}

// The live stream: one WebSocket, snapshots merged per robot.
function useLive(session) {
  const [robots, setRobots] = useState({});
  const [conn, setConn] = useState({ open: false, last: 0, closedWhy: null });
  const ws = useRef(null);
  const errors = useRef(() => {});
  useEffect(() => {
    if (!session) return undefined;
    let closed = false;
    let retry = null;
    const seqs = {};
    const connect = () => {
      const proto = location.protocol === "https:" ? "wss:" : "ws:";
      const sock = new WebSocket(`${proto}//${location.host}/console/ws`);
      ws.current = sock;
      sock.onopen = () => setConn((c) => ({ ...c, open: true, last: Date.now(), closedWhy: null }));
      sock.onmessage = (ev) => {
        const m = JSON.parse(ev.data);
        setConn((c) => ({ ...c, last: Date.now() }));
        if (m.type === "full") {
          seqs[m.robot] = m.seq;
          setRobots((r) => ({ ...r, [m.robot]: m.live }));
        } else if (m.type === "patch") {
          if (seqs[m.robot] !== undefined && m.seq !== seqs[m.robot] + 1) { sock.close(); return; }
          seqs[m.robot] = m.seq;
          setRobots((r) => ({ ...r, [m.robot]: applyPatch(r[m.robot], m.patch) }));
        } else if (m.type === "error") {
          errors.current(m.error);
        }
      };
      sock.onclose = (ev) => {
        setConn((c) => ({ ...c, open: false, closedWhy: ev.reason || `closed (${ev.code})` }));
        if (!closed) retry = setTimeout(connect, 1000);
      };
    };
    connect();
    return () => { closed = true; clearTimeout(retry); if (ws.current) ws.current.close(); };
  }, [session]);
  const send = useCallback((msg) => {
    if (ws.current && ws.current.readyState === 1) ws.current.send(JSON.stringify(msg));
  }, []);
  return { robots, conn, send, errors };
}

function useNow(ms) {
  const [now, setNow] = useState(Date.now());
  useEffect(() => { const t = setInterval(() => setNow(Date.now()), ms); return () => clearInterval(t); }, [ms]);
  return now;
}

function faultOf(live) {
  const s = live.state;
  if (s.fault || s.state === "fault") {
    return { why: `the PLC latched fault ${s.fault ?? ""}${s.refuses ? `: ${s.refuses}` : ""}`, action: "clear-fault", label: "Clear fault" };
  }
  if (s.cycle && s.cycle.state === "faulted") {
    return { why: `cycle ${s.cycle.program} faulted: ${s.cycle.reason || ""}`, action: "clear-fault", label: "Clear fault" };
  }
  if (s.phase === "link-down") return { why: `no link to the PLC: ${s.link.error || "connecting"}`, action: null };
  if (s.phase === "stalled") return { why: "the PLC's heartbeat stands still (stalled, or PROG mode)", action: null };
  if (s.phase === "unhomed" || (s.link.connected && !s.homed)) {
    return { why: "the robot is not homed", action: "home", label: "Home" };
  }
  return null;
}

function Header({ name, live, conn, session, act, seatTake, logout, now }) {
  const s = live.state;
  const stale = !conn.open || now - conn.last > STALE_MS;
  const seat = live.console.seat;
  const mine = seat && seat.user === session.user;
  return html`<header>
    <div class="title"><b data-test-id="robot-name">${name}</b>
      <span class="phase" data-test-id="phase">${s.phase}</span>
      <span class="mode" data-test-id="mode">${s.mode}</span>
      <span class=${`link ${s.link.connected && !stale ? "up" : "down"}`} data-test-id="link">
        ${stale ? (conn.open ? "no data" : `console ${conn.closedWhy || "disconnected"}`)
          : s.link.connected ? `PLC ${s.heartbeat_age_ms ?? "?"} ms` : "PLC link down"}</span>
      <span class="override" data-test-id="override-shown">speed ${live.speed_override_pct} %</span>
    </div>
    <div class="who">
      <span data-test-id="seat">${seat ? `seat: ${seat.user} (${seat.role})` : "seat: free"}</span>
      ${session.role !== "viewer" && !mine && s.mode === "local" &&
        html`<button data-test-id="seat-take" onClick=${seatTake}>Take control</button>`}
      <span data-test-id="user">${session.user} (${session.role})</span>
      <button class="small" onClick=${logout}>log out</button>
    </div>
    <button class="stop" data-test-id="stop" onClick=${() => act("POST", "stop")}>STOP</button>
  </header>`;
}

function FaultBanner({ live, act }) {
  const f = faultOf(live);
  if (!f) return null;
  return html`<div class="fault" data-test-id="fault">
    <span data-test-id="fault-reason">${f.why}</span>
    ${f.action && html`<button data-test-id=${f.action} onClick=${() => act("POST", f.action)}>${f.label}</button>`}
  </div>`;
}

// Top (x, y) and side (radius, z) views, drawn from the pose; the current move's line.
function RobotView({ info, live }) {
  const pose = live.state.pose;
  const reach = Math.max(300, ...(info.joints.filter((j) => j.unit === "mm").map((j) => Math.abs(j.max) + Math.abs(j.min))),
    (info.kinematics.params.l0_mm || 0) + 600);
  const size = 220;
  const k = (size / 2 - 10) / reach;
  const top = (x, y) => [size / 2 + x * k, size / 2 - y * k];
  const side = (r, z) => [20 + r * k, size - 20 - z * k];
  const path = live.path;
  let t = null; let sd = null;
  if (pose) {
    const [x, y, z] = pose;
    const r = Math.hypot(x, y);
    t = top(x, y); sd = side(r, z);
  }
  return html`<section class="view" data-test-id="robot-view">
    <h2>Robot</h2>
    <div class="pose" data-test-id="pose">
      x <b data-test-id="pose-x">${fmt(pose && pose[0])}</b>
      y <b data-test-id="pose-y">${fmt(pose && pose[1])}</b>
      z <b data-test-id="pose-z">${fmt(pose && pose[2])}</b> mm,
      a <b data-test-id="pose-a">${fmt(pose && pose[3])}</b>°,
      speed <b data-test-id="speed">${fmt(live.speed_mm_s, 1)}</b> mm/s
    </div>
    <svg width=${size} height=${size} class="top"><title>top (x, y)</title>
      <circle cx=${size / 2} cy=${size / 2} r="6" class="base" />
      ${path && html`<line class="path" x1=${top(path[0][0], path[0][1])[0]} y1=${top(path[0][0], path[0][1])[1]}
        x2=${top(path[1][0], path[1][1])[0]} y2=${top(path[1][0], path[1][1])[1]} />`}
      ${t && html`<line class="arm" x1=${size / 2} y1=${size / 2} x2=${t[0]} y2=${t[1]} />
        <circle cx=${t[0]} cy=${t[1]} r="5" class="tool" />`}
    </svg>
    <svg width=${size} height=${size} class="side"><title>side (radius, z)</title>
      <line class="floor" x1="0" y1=${size - 20} x2=${size} y2=${size - 20} />
      ${path && html`<line class="path" x1=${side(Math.hypot(path[0][0], path[0][1]), path[0][2])[0]}
        y1=${side(Math.hypot(path[0][0], path[0][1]), path[0][2])[1]}
        x2=${side(Math.hypot(path[1][0], path[1][1]), path[1][2])[0]}
        y2=${side(Math.hypot(path[1][0], path[1][1]), path[1][2])[1]} />`}
      ${sd && html`<line class="arm" x1="20" y1=${sd[1]} x2=${sd[0]} y2=${sd[1]} />
        <line class="column" x1="20" y1=${size - 20} x2="20" y2=${sd[1]} />
        <circle cx=${sd[0]} cy=${sd[1]} r="5" class="tool" />`}
    </svg>
  </section>`;
}

function Joints({ info, live }) {
  return html`<section data-test-id="joints"><h2>Joints</h2>
    ${info.joints.map((j, i) => {
      const v = live.joints ? live.joints[i] : null;
      const share = v == null ? 0 : Math.min(1, Math.max(0, (v - j.min) / (j.max - j.min)));
      return html`<div class="joint"><span class="jname">${j.name}</span>
        <span class="bar"><span class="mark" style=${`left:${share * 100}%`}></span></span>
        <span data-test-id=${`joint-${i}`}>${fmt(v, 2)}</span> ${j.unit}
        <small>${j.min} … ${j.max}</small></div>`;
    })}
  </section>`;
}

function Signals({ live }) {
  return html`<section data-test-id="signals"><h2>Inputs and outputs</h2>
    ${live.signals.length === 0 && html`<p class="note">no signals named in the config</p>`}
    ${live.signals.map((s) => html`<div class="signal">
      <span class=${`lamp ${s.value === true ? "on" : s.value === false ? "off" : "unknown"}`}
        data-test-id=${`signal-${s.name}`} data-value=${String(s.value)}></span>
      ${s.name} <small>${s.address}${s.value == null ? " (not in the status block)" : ""}</small></div>`)}
  </section>`;
}

const AXES = ["x", "y", "z", "a"];

function Jog({ name, info, live, session, send, act, can }) {
  const [mode, setMode] = useState("hold");
  const [step, setStep] = useState(1);
  const [frame, setFrame] = useState("tool");
  const held = useRef(null);
  const seq = useRef(0);
  const jog = live.console.jog;
  const stopHold = useCallback((why) => {
    if (!held.current) return;
    clearInterval(held.current.timer);
    held.current = null;
    send(why === "hidden" ? { type: "hidden" } : { type: "release", robot: name });
  }, [name, send]);
  useEffect(() => {
    const hidden = () => stopHold("hidden");
    const vis = () => { if (document.visibilityState !== "visible") stopHold("hidden"); };
    window.addEventListener("blur", hidden);
    window.addEventListener("pagehide", hidden);
    document.addEventListener("visibilitychange", vis);
    return () => {
      window.removeEventListener("blur", hidden);
      window.removeEventListener("pagehide", hidden);
      document.removeEventListener("visibilitychange", vis);
    };
  }, [stopHold]);
  const down = (axis, positive) => (e) => {
    if (mode !== "hold" || !can) return;
    e.preventDefault();
    if (e.target.setPointerCapture) { try { e.target.setPointerCapture(e.pointerId); } catch (_) { /* */ } }
    seq.current += 1;
    send({ type: "jog", robot: name, axis, positive, seq: seq.current });
    const timer = setInterval(() => { seq.current += 1; send({ type: "keep", robot: name, seq: seq.current }); }, KEEP_MS);
    held.current = { timer };
  };
  const up = () => stopHold("release");
  const stepJog = (axis, positive) => () => {
    if (mode !== "step" || !can) return;
    const d = positive ? step : -step;
    if (frame === "tool") {
      const by = [0, 0, 0, 0];
      by[AXES.indexOf(axis)] = d;
      act("POST", "moves", { by, speed_mm_s: info.manual_speed_mm_s });
    } else if (live.joints) {
      const joints = live.joints.slice();
      joints[axis] += d;
      act("POST", "moves", { joints, speed_mm_s: info.manual_speed_mm_s });
    }
  };
  const keys = frame === "tool" || mode === "hold" ? AXES : info.joints.map((_, i) => i);
  const label = (k) => (typeof k === "number" ? info.joints[k].name : k.toUpperCase());
  return html`<section class="jog" data-test-id="jog"><h2>Jog</h2>
    <div class="row">
      <button class=${mode === "hold" ? "on" : ""} data-test-id="jog-mode-hold" onClick=${() => setMode("hold")}>hold to run</button>
      <button class=${mode === "step" ? "on" : ""} data-test-id="jog-mode-step" onClick=${() => setMode("step")}>step</button>
      ${mode === "step" && [0.1, 1, 10].map((s) => html`<button class=${step === s ? "on" : ""}
        data-test-id=${`jog-step-${s}`} onClick=${() => setStep(s)}>${s}</button>`)}
      ${mode === "step" && html`<button class=${frame === "tool" ? "on" : ""} data-test-id="jog-frame-tool" onClick=${() => setFrame("tool")}>tool</button>
        <button class=${frame === "joints" ? "on" : ""} data-test-id="jog-frame-joints" onClick=${() => setFrame("joints")}>joints</button>`}
    </div>
    <div class="pad">
      ${keys.map((k) => html`<div class="axis">
        ${[false, true].map((positive) => html`<button class="jogkey" disabled=${!can || (mode === "step" && live.state.current_move != null)}
          data-test-id=${`jog-${typeof k === "number" ? `j${k + 1}` : k}-${positive ? "plus" : "minus"}`}
          onPointerDown=${down(k, positive)} onPointerUp=${up} onPointerCancel=${up}
          onLostPointerCapture=${up} onClick=${stepJog(k, positive)}>${label(k)}${positive ? "+" : "−"}</button>`)}
      </div>`)}
    </div>
    <p class="note" data-test-id="jog-info">
      ${jog.active ? html`<b data-test-id="jog-active">jogging ${jog.active.axis}${jog.active.positive ? "+" : "−"} (${jog.active.user})</b>` : "no jog"}
      · speed ${fmt(jog.speed_mm_s, 1)} mm/s (manual ${fmt(jog.manual_speed_mm_s, 0)}, override ${live.speed_override_pct} %)
      · lease ${jog.lease_ms} ms · worst-case travel after the last keep-alive:
      <b data-test-id="travel-alive">${fmt(jog.travel_alive_mm, 1)}</b> mm,
      <b data-test-id="travel-hung">${fmt(jog.travel_hung_mm, 1)}</b> mm with the daemon hung or the cable cut
      ${jog.refuses && html`<br /><span class="warn" data-test-id="jog-refuses">jog refused: ${jog.refuses}</span>`}
      ${jog.last_end && html`<br /><span data-test-id="jog-last-end">last jog ended: ${jog.last_end}</span>`}
    </p>
    <p class="note">The console's jog is a convenience, never a safety function: the e-stop is the hard-wired one.</p>
  </section>`;
}

function Override({ live, act, can }) {
  const [value, setValue] = useState(live.speed_override_pct);
  useEffect(() => setValue(live.speed_override_pct), [live.speed_override_pct]);
  return html`<section data-test-id="override"><h2>Speed override</h2>
    <input type="range" min="1" max="100" value=${value} disabled=${!can} data-test-id="speed-override"
      onInput=${(e) => setValue(Number(e.target.value))}
      onChange=${(e) => act("PUT", "speed-override", { percent: Number(e.target.value) })} />
    <b>${value} %</b> <small>of every move planned from now on (moves, jogs, cycles)</small>
  </section>`;
}

function Positions({ name, live, act, can, role, info }) {
  const [list, setList] = useState([]);
  const [newName, setNewName] = useState("");
  const [speed, setSpeed] = useState(info.manual_speed_mm_s);
  const load = useCallback(async () => {
    try { setList((await call("GET", `/v1/robots/${name}/positions`)).positions); } catch (_) { /* */ }
  }, [name]);
  useEffect(() => { load(); }, [load, live.state.current_move]);
  return html`<section data-test-id="positions"><h2>Taught positions</h2>
    <div class="row"><input placeholder="name" value=${newName} data-test-id="teach-name"
      onInput=${(e) => setNewName(e.target.value)} />
      <button disabled=${!can} data-test-id="teach" onClick=${async () => { await act("PUT", `positions/${newName}`); load(); }}>teach here</button>
      speed <input type="number" class="num" value=${speed} onInput=${(e) => setSpeed(Number(e.target.value))} /> mm/s</div>
    ${list.map((p) => html`<div class="position"><b>${p.name}</b>
      <small>${p.pose.map((v) => fmt(v, 1)).join(", ")}</small>
      <button disabled=${!can} data-test-id=${`goto-${p.name}`} onClick=${() => act("POST", "moves", { position: p.name, speed_mm_s: speed })}>go to</button>
      ${role === "admin" && html`<button class="small" onClick=${async () => { await act("DELETE", `positions/${p.name}`); load(); }}>delete</button>`}
    </div>`)}
  </section>`;
}

function SpeedPlot({ live }) {
  const el = useRef(null);
  const plot = useRef(null);
  const data = useRef([[], []]);
  useEffect(() => {
    if (!window.uPlot || !el.current) return undefined;
    plot.current = new window.uPlot({
      width: 420, height: 140, scales: { x: { time: false } },
      series: [{ label: "s ago" }, { label: "tool speed mm/s", stroke: "#2a7" }],
    }, data.current, el.current);
    return () => plot.current && plot.current.destroy();
  }, []);
  useEffect(() => {
    const [t, v] = data.current;
    t.push(Date.now() / 1000); v.push(live.speed_mm_s ?? 0);
    while (t.length > 300) { t.shift(); v.shift(); }
    const now = t[t.length - 1];
    if (plot.current) plot.current.setData([t.map((x) => x - now), v.slice()]);
  }, [live.reads]);
  return html`<div ref=${el} data-test-id="speed-plot"></div>`;
}

// The tool's distance from the running move's planned line at each status read, against the
// distance along it; kept for the last move, with its predicted largest deviation.
function lineOffset(path, pose) {
  const [a, b] = path;
  const d = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
  const len = Math.hypot(...d);
  const p = [pose[0] - a[0], pose[1] - a[1], pose[2] - a[2]];
  if (len < 1e-9) return [0, Math.hypot(...p)];
  const along = (p[0] * d[0] + p[1] * d[1] + p[2] * d[2]) / len;
  const off = [p[0] - (d[0] * along) / len, p[1] - (d[1] * along) / len, p[2] - (d[2] * along) / len];
  return [along, Math.hypot(...off)];
}

function DeviationPlot({ live }) {
  const el = useRef(null);
  const plot = useRef(null);
  const run = useRef({ id: null, along: [], dev: [] });
  const [shown, setShown] = useState(null);
  useEffect(() => {
    const cur = live.current;
    const pose = live.state.pose;
    if (cur && live.path && pose) {
      if (run.current.id !== cur.id) run.current = { id: cur.id, along: [], dev: [], predicted: cur.predicted };
      const [along, dev] = lineOffset(live.path, pose);
      run.current.along.push(along); run.current.dev.push(dev);
    } else if (run.current.id != null && run.current.along.length > 1) {
      setShown(run.current);
      run.current = { id: null, along: [], dev: [] };
    }
  }, [live.reads]);
  useEffect(() => {
    if (!shown || !window.uPlot || !el.current) return undefined;
    if (plot.current) plot.current.destroy();
    const order = shown.along.map((_, i) => i).sort((i, j) => shown.along[i] - shown.along[j]);
    plot.current = new window.uPlot({
      width: 420, height: 140, scales: { x: { time: false } },
      series: [{ label: "mm along the line" }, { label: "distance from the line, mm", stroke: "#c62828" }],
    }, [order.map((i) => shown.along[i]), order.map((i) => shown.dev[i])], el.current);
    return () => plot.current && plot.current.destroy();
  }, [shown]);
  return html`<div data-test-id="deviation-plot">
    ${shown && html`<small>move ${shown.id}: the tool's distance from its line at each status read
      (largest ${fmt(Math.max(...shown.dev), 3)} mm${shown.predicted ? `; predicted path deviation ${fmt(shown.predicted.path_deviation_mm, 4)} mm, tracking ${fmt(shown.predicted.tracking_error_mm, 4)} mm` : ""})</small>`}
    <div ref=${el}></div></div>`;
}

function Moves({ live }) {
  const cur = live.current;
  const last = live.last;
  return html`<section data-test-id="moves"><h2>Moves</h2>
    ${cur ? html`<div>move <b data-test-id="current-move">${cur.id}</b> ${cur.stage}
      <progress max="1" value=${cur.progress}></progress> ${fmt(cur.progress * 100, 0)} %
      ${cur.predicted && html`<small>predicted deviation ${fmt(cur.predicted.path_deviation_mm, 4)} mm, ${fmt(cur.predicted.duration_s, 2)} s</small>`}</div>`
      : html`<div>no move running; queued: ${live.state.queued.length}</div>`}
    ${last && html`<div data-test-id="last-move">last: move ${last.id} <b>${last.stage}</b>
      ${last.predicted && html`, predicted deviation ${fmt(last.predicted.path_deviation_mm, 4)} mm`}
      ${last.final_error_pulses && html`, final error ${last.final_error_pulses.join(" ")} pulses`}
      ${last.error && html`<br /><span class="warn">${last.error}</span>`}</div>`}
    <${DeviationPlot} live=${live} />
    <${SpeedPlot} live=${live} />
  </section>`;
}

function Cycles({ name, live, act, can, info }) {
  const [programs, setPrograms] = useState([]);
  const [program, setProgram] = useState("");
  const [count, setCount] = useState(1);
  useEffect(() => {
    if (!info.programs) return;
    call("GET", `/console/robots/${name}/programs`).then((p) => {
      setPrograms(p);
      if (p.length && !program) setProgram(p[0].name);
    }).catch(() => {});
  }, [name]);
  const c = live.state.cycle;
  const checked = programs.find((p) => p.name === program);
  return html`<section data-test-id="cycles"><h2>Cycles</h2>
    ${!info.programs ? html`<p class="note">no programs directory for this robot</p>` : html`
    <div class="row"><select data-test-id="cycle-program" value=${program} onChange=${(e) => setProgram(e.target.value)}>
      ${programs.map((p) => html`<option value=${p.name}>${p.name}${p.ok ? "" : " (does not check)"}</option>`)}</select>
      count <input type="number" class="num" min="1" value=${count} data-test-id="cycle-count" onInput=${(e) => setCount(Number(e.target.value))} />
      <button disabled=${!can} data-test-id="cycle-run" onClick=${() => act("POST", "cycles", { program, count })}>run</button>
      <button disabled=${!can} data-test-id="cycle-pause" onClick=${() => act("POST", "cycles/pause")}>pause</button>
      <button disabled=${!can} data-test-id="cycle-resume" onClick=${() => act("POST", "cycles/resume")}>resume</button>
      <button data-test-id="cycle-stop" onClick=${() => act("POST", "cycles/stop", {})}>stop</button></div>
    ${checked && !checked.ok && html`<p class="warn" data-test-id="cycle-check">${checked.error}</p>`}`}
    ${c && html`<div data-test-id="cycle-status">${c.program}: <b data-test-id="cycle-state">${c.state}</b>,
      <span data-test-id="cycle-done">${c.done}</span>${c.count ? ` of ${c.count}` : ""} done
      ${c.step && html`<br />step ${c.step.step}${c.step.label ? ` (${c.step.label})` : ""}: ${c.step.does}`}
      ${c.waiting_for && html`<br />waiting for ${c.waiting_for} (${fmt(c.waiting_s, 1)} s)`}
      ${c.reason && html`<br /><span class="warn">${c.reason}</span>`}
      ${c.last_cycle_s && html`<br />last cycle ${fmt(c.last_cycle_s, 2)} s, ${fmt(c.last_cycle_waiting_s, 2)} s of it waiting`}</div>`}
  </section>`;
}

function Mode({ live, act, role }) {
  if (role !== "admin") return null;
  const other = live.state.mode === "local" ? "remote" : "local";
  return html`<section><h2>Mode</h2>${live.state.mode}
    <button data-test-id="mode-switch" onClick=${() => act("PUT", "mode", { mode: other })}>switch to ${other}</button></section>`;
}

function Console({ session, logout }) {
  const { robots, conn, send, errors } = useLive(session);
  const [infos, setInfos] = useState([]);
  const [chosen, setChosen] = useState(null);
  const [error, setError] = useState(null);
  const now = useNow(500);
  errors.current = setError;
  useEffect(() => { call("GET", "/console/robots").then(setInfos).catch((e) => setError(e.message)); }, []);
  const name = chosen || (infos[0] && infos[0].name);
  const info = infos.find((i) => i.name === name);
  const live = name && robots[name];
  if (!info || !live) return html`<p class="loading" data-test-id="loading">connecting…</p>`;
  const act = async (method, what, body) => {
    try { setError(null); await call(method, `/v1/robots/${name}/${what}`, body); } catch (e) { setError(e.message); }
  };
  const seat = live.console.seat;
  const can = session.role !== "viewer" && seat && seat.user === session.user && live.state.mode === "local";
  return html`<div class="console">
    <${Header} name=${name} live=${live} conn=${conn} session=${session} act=${act} now=${now}
      seatTake=${() => send({ type: "take-seat", robot: name })} logout=${logout} />
    ${infos.length > 1 && html`<nav>${infos.map((i) => html`<button onClick=${() => setChosen(i.name)}>${i.name}</button>`)}</nav>`}
    <${FaultBanner} live=${live} act=${act} />
    ${error && html`<div class="error" data-test-id="error" onClick=${() => setError(null)}>${error}</div>`}
    <main>
      <${RobotView} info=${info} live=${live} />
      <${Jog} name=${name} info=${info} live=${live} session=${session} send=${send} act=${act} can=${can} />
      <${Joints} info=${info} live=${live} />
      <${Signals} live=${live} />
      <${Override} live=${live} act=${act} can=${can} />
      <${Positions} name=${name} live=${live} act=${act} can=${can} role=${session.role} info=${info} />
      <${Moves} live=${live} />
      <${Cycles} name=${name} live=${live} act=${act} can=${can} info=${info} />
      <${Mode} live=${live} act=${act} role=${session.role} />
    </main>
  </div>`;
}

function App() {
  const [session, setSession] = useState(undefined);
  useEffect(() => { call("GET", "/console/session").then(setSession).catch(() => setSession(null)); }, []);
  const logout = async () => { try { await call("POST", "/console/logout"); } catch (_) { /* */ } setSession(null); };
  if (session === undefined) return html`<p class="loading">…</p>`;
  if (!session) return html`<${Login} onDone=${setSession} />`;
  return html`<${Console} session=${session} logout=${logout} />`;
}

render(html`<${App} />`, document.getElementById("app"));
