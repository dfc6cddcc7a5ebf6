// mrmm console: the fleet on a map (the building's map under it, robots coloured by mission,
// patrol tours, coverage points, lanes held in traffic and who waits for whom),
// selection by click or box, and the operator's commands (assign, release, create, terminate).
// Data arrives as server-sent events (`/api/events`); commands are POSTs to `/api/…`. Text from
// the fleet is only ever set as text (never as HTML).
'use strict';
(() => {
  const token = (() => {
    const m = location.hash.match(/token=([0-9a-f]+)/);
    if (m) {
      sessionStorage.setItem('mrmm-token', m[1]);
      history.replaceState(null, '', location.pathname);
      return m[1];
    }
    return sessionStorage.getItem('mrmm-token') || '';
  })();

  const $ = (id) => document.getElementById(id);
  const canvas = $('map');
  const ctx = canvas.getContext('2d');
  let snap = { robots: [], missions: [], advice: [], central: { reachable: false } };
  const selected = new Set();
  let drawing = false;
  // The next click on the map sends the selected robot there.
  let going = false;
  const points = [];
  let view = { cx: 0, cy: 0, scale: 20, user: false };
  let drag = null;
  // A frame is asked for and not drawn yet.
  let dirty = false;
  // Central's maps as drawn layers, by hash: { info, json, img }.
  const layers = {};

  // ---- colours -------------------------------------------------------------------------------
  function hue(name) {
    let h = 0;
    for (const c of name) h = (h * 31 + c.codePointAt(0)) >>> 0;
    return h % 360;
  }
  const missionColour = (name) => (name ? `hsl(${hue(name)},65%,45%)` : '#8a93a3');

  // ---- geometry ------------------------------------------------------------------------------
  function size() {
    const dpr = window.devicePixelRatio || 1;
    const w = canvas.clientWidth, h = canvas.clientHeight;
    if (canvas.width !== Math.round(w * dpr) || canvas.height !== Math.round(h * dpr)) {
      canvas.width = Math.round(w * dpr);
      canvas.height = Math.round(h * dpr);
    }
    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    return { w, h };
  }
  function toScreen(x, y) {
    const { w, h } = { w: canvas.clientWidth, h: canvas.clientHeight };
    return [w / 2 + (x - view.cx) * view.scale, h / 2 - (y - view.cy) * view.scale];
  }
  function toWorld(sx, sy) {
    const { w, h } = { w: canvas.clientWidth, h: canvas.clientHeight };
    return [view.cx + (sx - w / 2) / view.scale, view.cy - (sy - h / 2) / view.scale];
  }
  function missionShapes(m) {
    const s = m.summary;
    if (!s) return { line: [], dots: [], area: [] };
    if (s.planner === 'patrol') return { line: s.tour || [], dots: [], area: [] };
    if (s.planner === 'coverage') return { line: [], dots: s.points || [], area: (s.region && s.region.outer) || [] };
    return { line: [], dots: [], area: [] };
  }
  function fit() {
    const xs = [], ys = [];
    const add = (x, y) => { if (Number.isFinite(x) && Number.isFinite(y)) { xs.push(x); ys.push(y); } };
    for (const r of snap.robots) if (r.pose) add(r.pose.x, r.pose.y);
    for (const m of snap.missions) {
      const sh = missionShapes(m);
      for (const p of [...sh.line, ...sh.dots, ...sh.area]) add(p.x, p.y);
    }
    for (const [x, y] of points) add(x, y);
    for (const m of snap.maps || []) if (layers[m.hash] && layers[m.hash].json) { add(m.min.x, m.min.y); add(m.max.x, m.max.y); }
    if (!xs.length) { add(0, 0); }
    const minX = Math.min(...xs), maxX = Math.max(...xs), minY = Math.min(...ys), maxY = Math.max(...ys);
    const spanX = Math.max(maxX - minX, 10), spanY = Math.max(maxY - minY, 10);
    const w = canvas.clientWidth || 800, h = canvas.clientHeight || 600;
    view.cx = (minX + maxX) / 2;
    view.cy = (minY + maxY) / 2;
    view.scale = Math.min(w / (spanX * 1.2), h / (spanY * 1.2));
  }

  // ---- drawing -------------------------------------------------------------------------------
  function draw() {
    dirty = false;
    const { w, h } = size();
    // The map follows the fleet, except while the operator zoomed or draws (points must stay
    // where they were clicked; the wheel zooms out to draw further).
    if (!view.user && !drawing) fit();
    ctx.clearRect(0, 0, w, h);
    grid(w, h);
    for (const l of Object.values(layers)) drawLayer(l);
    for (const m of snap.missions) {
      const col = missionColour(m.name);
      const sh = missionShapes(m);
      ctx.strokeStyle = col;
      ctx.fillStyle = col;
      ctx.lineWidth = 1.5;
      if (sh.area.length > 2) {
        ctx.setLineDash([4, 4]);
        path(sh.area.map((p) => [p.x, p.y]), true);
        ctx.stroke();
        ctx.setLineDash([]);
      }
      if (sh.line.length > 1) { path(sh.line.map((p) => [p.x, p.y]), true); ctx.stroke(); }
      for (const p of sh.dots) { const [sx, sy] = toScreen(p.x, p.y); ctx.fillRect(sx - 3, sy - 3, 6, 6); }
    }
    drawTraffic();
    if (points.length) {
      ctx.strokeStyle = '#d97706';
      ctx.fillStyle = '#d97706';
      ctx.setLineDash([6, 3]);
      path(points, points.length > 2);
      ctx.stroke();
      ctx.setLineDash([]);
      points.forEach(([x, y], i) => {
        const [sx, sy] = toScreen(x, y);
        ctx.beginPath(); ctx.arc(sx, sy, 4, 0, 2 * Math.PI); ctx.fill();
        ctx.fillText(String(i + 1), sx + 6, sy - 6);
      });
    }
    ctx.font = '12px system-ui, sans-serif';
    for (const r of snap.robots) {
      if (!r.pose) continue;
      const [sx, sy] = toScreen(r.pose.x, r.pose.y);
      const lost = r.status === 'lost';
      const col = lost ? '#b9bec8' : missionColour(r.mission);
      if (selected.has(r.id)) {
        ctx.strokeStyle = '#f59e0b'; ctx.lineWidth = 4;
        ctx.beginPath(); ctx.arc(sx, sy, 12, 0, 2 * Math.PI); ctx.stroke();
      }
      ctx.fillStyle = col;
      ctx.beginPath(); ctx.arc(sx, sy, 7, 0, 2 * Math.PI); ctx.fill();
      ctx.strokeStyle = '#1d2430'; ctx.lineWidth = 1.5;
      ctx.beginPath(); ctx.moveTo(sx, sy);
      ctx.lineTo(sx + 11 * Math.cos(r.pose.theta), sy - 11 * Math.sin(r.pose.theta)); ctx.stroke();
      if (r.stuck) { ctx.fillStyle = '#b42318'; ctx.fillText('!', sx - 2, sy - 10); }
      ctx.fillStyle = '#1d2430';
      ctx.fillText(r.id, sx + 10, sy + 14);
    }
    if (drag && drag.box) {
      ctx.strokeStyle = '#2b6cb0'; ctx.lineWidth = 1; ctx.setLineDash([3, 3]);
      ctx.strokeRect(drag.x0, drag.y0, drag.x1 - drag.x0, drag.y1 - drag.y0);
      ctx.setLineDash([]);
    }
  }
  // A map under the fleet: a grid's image placed in metres (its lower-left corner at the
  // origin, turned by its yaw), or a graph's lanes and vertices.
  function drawLayer(l) {
    const j = l.json;
    if (!j) return;
    if (j.kind === 'grid' && l.img && l.img.complete && l.img.naturalWidth) {
      const g = j.grid, [sx, sy] = toScreen(g.origin[0], g.origin[1]);
      const wpx = g.width * g.resolution * view.scale, hpx = g.height * g.resolution * view.scale;
      ctx.save();
      ctx.translate(sx, sy);
      ctx.rotate(-g.origin[2]);
      ctx.imageSmoothingEnabled = false;
      ctx.globalAlpha = 0.85;
      ctx.drawImage(l.img, 0, -hpx, wpx, hpx);
      ctx.restore();
      l.drawn = true;
    } else if (j.kind === 'graph') {
      ctx.strokeStyle = '#b6bdc9'; ctx.lineWidth = 2;
      for (const [x1, y1, x2, y2] of j.lanes) {
        const [a, b] = toScreen(x1, y1), [c, d] = toScreen(x2, y2);
        ctx.beginPath(); ctx.moveTo(a, b); ctx.lineTo(c, d); ctx.stroke();
      }
      ctx.fillStyle = '#9aa3b2';
      for (const [x, y] of j.vertices) { const [sx, sy] = toScreen(x, y); ctx.fillRect(sx - 2, sy - 2, 4, 4); }
      l.drawn = true;
    }
    // Its chargers: a green square each, named.
    if (l.drawn) {
      ctx.font = '11px sans-serif';
      for (const c of l.info.chargers || []) {
        const [sx, sy] = toScreen(c.at.x, c.at.y);
        ctx.fillStyle = '#1a7f37'; ctx.fillRect(sx - 5, sy - 5, 10, 10);
        ctx.fillStyle = '#fff'; ctx.fillText('+', sx - 3, sy + 4);
        ctx.fillStyle = '#1a7f37'; ctx.fillText(c.name, sx + 7, sy + 4);
      }
    }
  }
  // Traffic on graph maps: each robot's lanes held (from where it stands to where it may drive)
  // thick in its own colour, the rest of its route thin and dashed; a robot waiting gets a dashed
  // arrow to each robot in its way (red when traffic found no way round).
  // Ids that differ in one letter get hues far apart (the golden angle).
  const robotColour = (id) => `hsl(${Math.round((hue(id) * 137.508) % 360)},75%,42%)`;
  let trafficDrawn = [];
  function drawTraffic() {
    trafficDrawn = [];
    const poseOf = new Map(snap.robots.filter((r) => r.pose).map((r) => [r.id, r.pose]));
    for (const t of snap.traffic || []) {
      const l = layers[t.map];
      if (!l || !l.json) continue;
      for (const r of t.robots) {
        const col = r.lost ? '#8a93a3' : robotColour(r.robot);
        // Where each vertex of its route is (traffic cuts long lanes, and derives a grid map's:
        // not all are the map's own).
        const own = l.json.kind === 'graph' ? l.json.vertices : [];
        const pts = r.points && r.points.length === r.route.length ? r.points : r.route.map((v) => own[v]);
        const from = r.reached == null ? 0 : r.reached;
        const held = r.granted == null ? [] : pts.slice(from, r.granted + 1).filter(Boolean);
        const ahead = pts.slice(r.granted == null ? 0 : r.granted).filter(Boolean);
        ctx.strokeStyle = col;
        if (ahead.length > 1) {
          ctx.globalAlpha = 0.6; ctx.lineWidth = 1.5; ctx.setLineDash([5, 4]);
          path(ahead, false); ctx.stroke(); ctx.setLineDash([]);
        }
        ctx.globalAlpha = 0.5; ctx.lineWidth = 8;
        if (held.length > 1) { path(held, false); ctx.stroke(); }
        else if (held.length === 1) { const [sx, sy] = toScreen(held[0][0], held[0][1]); ctx.beginPath(); ctx.arc(sx, sy, 9, 0, 2 * Math.PI); ctx.stroke(); }
        ctx.globalAlpha = 1;
        const by = r.blocked.length ? r.blocked : r.waits_for;
        const p = poseOf.get(r.robot);
        for (const b of by) { const q = poseOf.get(b); if (p && q) arrow(p, q, r.blocked.length ? '#b42318' : '#d97706'); }
        trafficDrawn.push({ robot: r.robot, held: held.length, ahead: Math.max(ahead.length - 1, 0), waits_for: by, blocked: r.blocked.length > 0, lost: r.lost });
      }
    }
  }
  function arrow(p, q, col) {
    const [x1, y1] = toScreen(p.x, p.y), [x2, y2] = toScreen(q.x, q.y);
    const a = Math.atan2(y2 - y1, x2 - x1), back = 10;
    const ex = x2 - back * Math.cos(a), ey = y2 - back * Math.sin(a);
    ctx.strokeStyle = col; ctx.fillStyle = col; ctx.lineWidth = 2; ctx.setLineDash([4, 3]);
    ctx.beginPath(); ctx.moveTo(x1, y1); ctx.lineTo(ex, ey); ctx.stroke(); ctx.setLineDash([]);
    ctx.beginPath(); ctx.moveTo(ex, ey);
    ctx.lineTo(ex - 8 * Math.cos(a - 0.4), ey - 8 * Math.sin(a - 0.4));
    ctx.lineTo(ex - 8 * Math.cos(a + 0.4), ey - 8 * Math.sin(a + 0.4));
    ctx.closePath(); ctx.fill();
  }
  // Fetches the layers of maps not seen yet (asked again at a later snapshot if not ready).
  function loadLayers() {
    for (const m of snap.maps || []) {
      const have = layers[m.hash];
      if (have && (have.json || have.loading)) continue;
      const l = (layers[m.hash] = { info: m, loading: true });
      fetch(`/api/map/${m.hash}`, { headers: { Authorization: `Bearer ${token}` } })
        .then((r) => (r.ok ? r.json() : null))
        .then((j) => {
          l.loading = false;
          if (!j) return;
          l.json = j;
          if (j.kind === 'grid') {
            l.img = new Image();
            l.img.onload = () => redraw();
            l.img.src = `/api/map/${m.hash}/png?token=${encodeURIComponent(token)}`;
          }
          redraw();
        })
        .catch(() => { l.loading = false; });
    }
    const sel = $('new-map');
    const names = ['', ...(snap.maps || []).map((m) => m.name)];
    if (sel && sel.options.length !== names.length) {
      const keep = sel.value;
      sel.textContent = '';
      for (const n of names) { const o = document.createElement('option'); o.value = n; o.textContent = n || 'no map'; sel.appendChild(o); }
      sel.value = names.includes(keep) ? keep : '';
    }
  }
  function path(pts, closed) {
    ctx.beginPath();
    pts.forEach(([x, y], i) => { const [sx, sy] = toScreen(x, y); if (i) ctx.lineTo(sx, sy); else ctx.moveTo(sx, sy); });
    if (closed) ctx.closePath();
  }
  function grid(w, h) {
    const step = [1, 2, 5, 10, 20, 50, 100, 200, 500, 1000].find((s) => s * view.scale >= 40) || 1000;
    const [x0, y1] = toWorld(0, 0), [x1, y0] = toWorld(w, h);
    ctx.strokeStyle = '#eef0f3'; ctx.lineWidth = 1; ctx.fillStyle = '#9aa3b2'; ctx.font = '10px system-ui, sans-serif';
    for (let x = Math.ceil(x0 / step) * step; x <= x1; x += step) {
      const [sx] = toScreen(x, 0); ctx.beginPath(); ctx.moveTo(sx, 0); ctx.lineTo(sx, h); ctx.stroke(); ctx.fillText(`${x} m`, sx + 2, h - 4);
    }
    for (let y = Math.ceil(y0 / step) * step; y <= y1; y += step) {
      const [, sy] = toScreen(0, y); ctx.beginPath(); ctx.moveTo(0, sy); ctx.lineTo(w, sy); ctx.stroke(); ctx.fillText(`${y} m`, 2, sy - 2);
    }
  }
  const redraw = () => { if (!dirty) { dirty = true; requestAnimationFrame(draw); } };

  // ---- map interaction -----------------------------------------------------------------------
  function robotAt(sx, sy) {
    let best = null, bestD = 13;
    for (const r of snap.robots) {
      if (!r.pose) continue;
      const [x, y] = toScreen(r.pose.x, r.pose.y);
      const d = Math.hypot(x - sx, y - sy);
      if (d < bestD) { best = r.id; bestD = d; }
    }
    return best;
  }
  const local = (e) => { const b = canvas.getBoundingClientRect(); return [e.clientX - b.left, e.clientY - b.top]; };
  canvas.addEventListener('pointerdown', (e) => {
    const [x, y] = local(e);
    drag = { x0: x, y0: y, x1: x, y1: y, box: false, add: e.shiftKey || e.ctrlKey || e.metaKey };
    canvas.setPointerCapture(e.pointerId);
  });
  canvas.addEventListener('pointermove', (e) => {
    if (!drag) return;
    const [x, y] = local(e);
    drag.x1 = x; drag.y1 = y;
    if (Math.hypot(x - drag.x0, y - drag.y0) > 4) drag.box = true;
    if (drag.box) redraw();
  });
  canvas.addEventListener('pointerup', () => {
    if (!drag) return;
    const d = drag;
    drag = null;
    if (d.box) {
      if (!d.add) selected.clear();
      const [lx, hx] = [Math.min(d.x0, d.x1), Math.max(d.x0, d.x1)], [ly, hy] = [Math.min(d.y0, d.y1), Math.max(d.y0, d.y1)];
      for (const r of snap.robots) {
        if (!r.pose) continue;
        const [sx, sy] = toScreen(r.pose.x, r.pose.y);
        if (sx >= lx && sx <= hx && sy >= ly && sy <= hy) selected.add(r.id);
      }
    } else {
      // While drawing or choosing a destination a click is a point, even where a robot
      // stands (a waypoint may be where a robot is now); otherwise it selects.
      const id = going || drawing ? null : robotAt(d.x0, d.y0);
      if (going) {
        going = false;
        const [x, y] = toWorld(d.x0, d.y0);
        goto(Math.round(x * 10) / 10, Math.round(y * 10) / 10);
      } else if (drawing) {
        const [x, y] = toWorld(d.x0, d.y0);
        points.push([Math.round(x * 10) / 10, Math.round(y * 10) / 10]);
      } else if (id) {
        if (d.add) { if (selected.has(id)) selected.delete(id); else selected.add(id); } else { selected.clear(); selected.add(id); }
      } else if (!d.add) {
        selected.clear();
      }
    }
    render();
  });
  canvas.addEventListener('wheel', (e) => {
    e.preventDefault();
    const [sx, sy] = local(e);
    const [wx, wy] = toWorld(sx, sy);
    view.user = true;
    view.scale = Math.min(Math.max(view.scale * (e.deltaY < 0 ? 1.2 : 1 / 1.2), 0.05), 500);
    const [nx, ny] = toWorld(sx, sy);
    view.cx += wx - nx; view.cy += wy - ny;
    redraw();
  }, { passive: false });
  canvas.addEventListener('dblclick', () => { view.user = false; redraw(); });
  window.addEventListener('resize', redraw);

  // ---- panels --------------------------------------------------------------------------------
  function cell(tr, text, cls) { const td = document.createElement('td'); td.textContent = text; if (cls) td.className = cls; tr.appendChild(td); return td; }
  function button(td, label, onClick, attr) {
    const b = document.createElement('button'); b.textContent = label; b.addEventListener('click', onClick);
    if (attr) b.setAttribute(attr[0], attr[1]);
    td.appendChild(b); return b;
  }
  function figure(m) {
    const s = m.summary, x = m.metrics || {};
    if (s && s.planner === 'coverage') return `radius ${s.coverage_radius.toFixed(1)} m`;
    if (x.worst_idleness != null && x.rounds > 0) return `idle ≤ ${x.worst_idleness.toFixed(0)} s`;
    if (s && s.planner === 'patrol') return `tour ${s.length.toFixed(0)} m`;
    return '';
  }
  function render() {
    const c = snap.central || {};
    $('conn').textContent = c.reachable ? 'central: connected' : `central: ${c.error || 'not reached yet'}`;
    $('conn').className = c.reachable ? 'ok' : 'bad';
    const lost = snap.robots.filter((r) => r.status === 'lost').length;
    $('counts').textContent = `${snap.robots.length} robots (${lost} lost) · ${snap.missions.length} missions`;
    for (const id of [...selected]) if (!snap.robots.some((r) => r.id === id)) selected.delete(id);
    $('selection').textContent = selected.size ? [...selected].sort().join(', ') : 'none';

    const mt = $('missions').tBodies[0];
    mt.replaceChildren();
    for (const m of snap.missions) {
      const tr = document.createElement('tr');
      tr.dataset.mission = m.name;
      const name = cell(tr, '');
      const sw = document.createElement('span'); sw.className = 'swatch'; sw.style.background = missionColour(m.name);
      name.append(sw, document.createTextNode(m.name));
      if (m.requires && m.requires.length) {
        const need = document.createElement('small'); need.textContent = ` needs ${m.requires.join(', ')}`; need.dataset.requires = m.requires.join(',');
        name.appendChild(need);
      }
      cell(tr, m.status + (m.manager && m.manager.uncommitted_s ? ' (not committing)' : ''));
      cell(tr, `${m.robots.length}${m.lost && m.lost.length ? ` +${m.lost.length} lost` : ''}`);
      cell(tr, figure(m));
      const act = cell(tr, '');
      button(act, 'Assign selected', () => assign(m.name), ['data-assign', m.name]);
      button(act, 'Edit', () => editMission(m), ['data-edit', m.name]);
      if (m.status === 'paused') button(act, 'Resume', () => pause(m.name, false), ['data-resume', m.name]);
      else button(act, 'Pause', () => pause(m.name, true), ['data-pause', m.name]);
      button(act, 'End', () => terminate(m.name), ['data-terminate', m.name]);
      mt.appendChild(tr);
      // A mission of teams: one row per leaf team, below the mission, indented by its depth.
      for (const t of m.team_views || []) {
        const sub = document.createElement('tr');
        sub.className = 'team';
        sub.dataset.team = t.team;
        const path = t.team.slice(m.name.length + 1);
        cell(sub, `${'\u00a0\u00a0'.repeat(path.split('/').length)}${path}`);
        cell(sub, t.planner);
        cell(sub, `${t.members.length}${t.min ? ` (min ${t.min})` : ''}`, t.members.length < t.min ? 'short' : undefined);
        cell(sub, `${t.barriers_passed} barriers`);
        cell(sub, t.members.join(', '));
        mt.appendChild(sub);
      }
    }
    const teamOf = new Map();
    for (const m of snap.missions) for (const t of m.team_views || []) for (const id of t.members) teamOf.set(id, t.team);
    const rt = $('robots').tBodies[0];
    rt.replaceChildren();
    // Robots grouped by team (a mission's teams side by side), then by id.
    const byTeam = [...snap.robots].sort((a, b) => (teamOf.get(a.id) || a.mission || '\uffff').localeCompare(teamOf.get(b.id) || b.mission || '\uffff'));
    for (const r of byTeam) {
      const tr = document.createElement('tr');
      tr.dataset.robot = r.id;
      if (selected.has(r.id)) tr.className = 'selected';
      cell(tr, r.id); cell(tr, r.type); cell(tr, (r.capabilities || []).join(', ') || '—', 'caps');
      cell(tr, r.stuck ? `${r.status} (stuck)` : r.status);
      const b = r.battery;
      cell(tr, b ? `${Math.round(b.charge * 100)}%${b.charging ? ' charging' : ''}` : '—', b && b.charge < 0.2 && !b.charging ? 'short' : undefined).title =
        b && b.reach_m != null ? `reaches ${Math.round(b.reach_m)} m` : '';
      cell(tr, teamOf.get(r.id) || r.mission || '—');
      cell(tr, r.stuck || r.behaviour || '', 'doing').title = r.stuck || r.behaviour || '';
      tr.addEventListener('click', (e) => {
        if (!(e.shiftKey || e.ctrlKey || e.metaKey)) { const had = selected.has(r.id) && selected.size === 1; selected.clear(); if (!had) selected.add(r.id); }
        else if (selected.has(r.id)) selected.delete(r.id); else selected.add(r.id);
        render();
      });
      rt.appendChild(tr);
    }
    const tt = $('traffic').tBodies[0];
    tt.replaceChildren();
    for (const t of snap.traffic || []) {
      for (const r of t.robots) {
        const tr = document.createElement('tr');
        tr.dataset.traffic = r.robot;
        const name = cell(tr, '');
        const sw = document.createElement('span'); sw.className = 'swatch'; sw.style.background = robotColour(r.robot);
        name.append(sw, document.createTextNode(r.robot));
        const arrived = r.reached != null && r.reached + 1 === r.route.length;
        const state = r.lost ? 'lost' : r.blocked.length ? 'BLOCKED' : r.waiting_s != null ? `waiting ${r.waiting_s.toFixed(0)} s` : arrived ? 'arrived' : 'driving';
        cell(tr, state, r.lost || r.blocked.length ? 'short' : undefined);
        cell(tr, `${r.holds.length}`);
        cell(tr, (r.blocked.length ? r.blocked : r.waits_for).join(', ') || '—');
        const act = cell(tr, '');
        if (r.lost) button(act, 'Take off lanes', () => clearTraffic(r.robot), ['data-clear', r.robot]).title = 'Only once the robot is gone from there: what it held is freed for the robots waiting';
        tt.appendChild(tr);
      }
    }
    $('traffic-box').hidden = !(snap.traffic || []).some((t) => t.robots.length);
    const ul = $('advice');
    ul.replaceChildren();
    for (const a of snap.advice) {
      const li = document.createElement('li'); li.className = a.priority;
      li.textContent = a.reason;
      if (a.suggestion) { const code = document.createElement('code'); code.textContent = ` ${a.suggestion}`; li.appendChild(code); }
      if (a.action && !a.acted) {
        const b = document.createElement('button');
        b.textContent = 'Apply';
        b.dataset.apply = a.id;
        b.addEventListener('click', () => applyAdvice(a.action));
        li.append(' ', b);
      }
      ul.appendChild(li);
    }
    $('points').textContent = `${points.length} point${points.length === 1 ? '' : 's'}`;
    $('draw').setAttribute('aria-pressed', String(drawing));
    $('goto').setAttribute('aria-pressed', String(going));
    redraw();
  }

  // ---- commands ------------------------------------------------------------------------------
  function say(text, ok) { const m = $('message'); m.textContent = text; m.className = ok ? 'ok' : 'error'; }
  async function api(path, body) {
    const r = await fetch(path, { method: 'POST', headers: { Authorization: `Bearer ${token}`, 'Content-Type': 'application/json' }, body: JSON.stringify(body) });
    let j = null;
    try { j = await r.json(); } catch (_) { /* not JSON */ }
    if (!r.ok && r.status !== 207) throw new Error((j && j.error) || `${r.status} ${r.statusText}`);
    return j;
  }
  async function moveSelected(to) {
    const robots = [...selected].sort();
    if (!robots.length) return say('Select robots first: click them on the map, or drag a box.', false);
    say(`${to ? `Assigning ${robots.join(', ')} to ${to}` : `Releasing ${robots.join(', ')}`}…`, true);
    try {
      const j = await api('/api/assign', { robots, to });
      const failed = j.results.filter((m) => !m.ok);
      if (failed.length) say(failed.map((m) => `${m.robot}: ${m.error}`).join('; '), false);
      else say(to ? `${robots.join(', ')} → ${to}` : `${robots.join(', ')} released`, true);
    } catch (e) { say(e.message, false); }
  }
  const assign = (name) => moveSelected(name);
  async function clearTraffic(id) {
    try {
      const j = await api('/api/cmd/traffic/clear', { robot: id });
      say(`${id} taken off the lanes: ${j.vertices} vertices freed`, true);
    } catch (e) { say(`${id}: ${e.message}`, false); }
  }
  async function goto(x, y) {
    const [robot] = [...selected];
    try {
      const j = await api('/api/cmd/robot/goto', { robot, x, y });
      say(`${j.robot} → (${x}, ${y})`, true);
    } catch (e) { say(e.message, false); }
    render();
  }
  // Charge: the selected robot to a charger now; one charging (or on its way), released.
  async function charge() {
    if (selected.size !== 1) return say('Select one robot, then click Charge.', false);
    const [robot] = [...selected];
    const r = snap.robots.find((x) => x.id === robot);
    const charging = r && r.battery && r.battery.charging;
    try {
      if (charging) {
        await api('/api/cmd/robot/release', { robot });
        say(`${robot} released from charging`, true);
      } else {
        const j = await api('/api/cmd/robot/charge', { robot });
        say(`${robot} → charger ${j.charger.name}`, true);
      }
    } catch (e) { say(`${robot}: ${e.message}`, false); }
    render();
  }
  async function capabilities() {
    if (selected.size !== 1) return say('Select one robot, then click Capabilities… to say what it can do now.', false);
    const [robot] = [...selected];
    const r = snap.robots.find((x) => x.id === robot);
    const had = (r && r.capabilities) || [];
    const text = window.prompt(`What can ${robot} do now? Capabilities, comma-separated (a robot leaves a mission that requires one it no longer has):`, had.join(', '));
    if (text === null) return;
    const now = [...new Set(text.split(',').map((c) => c.trim()).filter((c) => c))];
    const add = now.filter((c) => !had.includes(c)), remove = had.filter((c) => !now.includes(c));
    if (!add.length && !remove.length) return say(`${robot}: no change`, true);
    try {
      const j = await api('/api/cmd/robot/capabilities', { robot, add, remove });
      const has = (j.capabilities || []).join(', ') || 'no capabilities';
      say(`${j.robot}: ${has}${j.left ? `; it left ${j.left}, which requires what it no longer has` : ''}`, true);
    } catch (e) { say(e.message, false); }
  }
  async function applyAdvice(action) {
    say(`Moving ${action.robot} to ${action.to || 'idle'}…`, true);
    try {
      const j = await api('/api/assign', { robots: [action.robot], to: action.to });
      const failed = j.results.filter((m) => !m.ok);
      if (failed.length) say(failed.map((m) => `${m.robot}: ${m.error}`).join('; '), false);
      else say(`${action.robot} → ${action.to || 'idle'}`, true);
    } catch (e) { say(e.message, false); }
  }
  async function pause(name, paused) {
    try {
      await api(`/api/cmd/mission/${paused ? 'pause' : 'resume'}`, { name });
      say(paused ? `${name} paused: its robots hold where they are` : `${name} resumed`, true);
    } catch (e) { say(e.message, false); }
  }
  // The points drawn on the map become the mission's new waypoints (a patrol) or region (a
  // coverage): checked by central, replanned by its head as the next epoch, same members.
  async function editMission(m) {
    if (points.length < 3) return say(`Draw ${m.name}'s new ${m.planner === 'coverage' ? 'region' : 'waypoints'} on the map (at least 3 points), then Edit.`, false);
    const params = { [m.planner === 'coverage' ? 'region' : 'waypoints']: points.map(([x, y]) => [x, y]) };
    try {
      await api('/api/cmd/mission/update', { name: m.name, params });
      say(`${m.name} replanned with the new ${m.planner === 'coverage' ? 'region' : 'waypoints'}`, true);
      points.length = 0; drawing = false; render();
    } catch (e) { say(e.message, false); }
  }
  async function terminate(name) {
    if (!window.confirm(`End mission ${name}? Its robots become idle.`)) return;
    try { await api('/api/cmd/mission/terminate', { name }); say(`${name} ended`, true); } catch (e) { say(e.message, false); }
  }
  async function create() {
    const name = $('new-name').value.trim(), recipe = $('new-recipe').value;
    const robots = [...selected].sort();
    if (!/^[A-Za-z0-9_-]{1,64}$/.test(name)) return say('Name the mission: 1 to 64 of A-Z a-z 0-9 _ -', false);
    if (!robots.length) return say('Select the robots of the new mission first.', false);
    const params = {};
    if (points.length) {
      if (points.length < 3) return say('Draw at least 3 points (or none for the recipe\'s own).', false);
      params[recipe === 'coverage' ? 'region' : 'waypoints'] = points.map(([x, y]) => [x, y]);
    }
    say(`Creating ${name} with ${robots.join(', ')}…`, true);
    const map = $('new-map').value;
    try {
      const v = await api('/api/cmd/mission/create', map ? { name, recipe, robots, params, map } : { name, recipe, robots, params });
      say(`${v.name} ${v.status} with ${v.robots.join(', ')}`, true);
      points.length = 0; drawing = false; render();
    } catch (e) { say(e.message, false); }
  }
  $('clear').addEventListener('click', () => { selected.clear(); render(); });
  $('release').addEventListener('click', () => moveSelected(null));
  $('draw').addEventListener('click', () => { drawing = !drawing; going = false; render(); });
  $('goto').addEventListener('click', () => {
    if (selected.size !== 1) { going = false; say('Select one idle robot, then click Go to… and a point on the map.', false); return render(); }
    going = !going; drawing = false;
    if (going) say(`Click where ${[...selected][0]} should go.`, true);
    render();
  });
  $('caps').addEventListener('click', capabilities);
  $('charge').addEventListener('click', charge);
  $('undo-point').addEventListener('click', () => { points.pop(); render(); });
  $('clear-points').addEventListener('click', () => { points.length = 0; render(); });
  $('create').addEventListener('click', create);

  // ---- the feed ------------------------------------------------------------------------------
  function connect() {
    const es = new EventSource(`/api/events?token=${encodeURIComponent(token)}`);
    es.addEventListener('state', (e) => { try { snap = JSON.parse(e.data); loadLayers(); render(); } catch (err) { say(`bad state: ${err}`, false); } });
    es.onerror = () => { $('conn').textContent = 'console: reconnecting…'; $('conn').className = 'bad'; };
  }
  if (!token) say('No token: open the URL that `mrmm console` printed.', false);
  connect();
  render();

  // For tests and scripts: where a robot is drawn, in page coordinates.
  window.mrmmConsole = {
    robotOnPage(id) {
      const r = snap.robots.find((x) => x.id === id);
      if (!r || !r.pose) return null;
      const b = canvas.getBoundingClientRect();
      const [sx, sy] = toScreen(r.pose.x, r.pose.y);
      return { x: b.left + sx, y: b.top + sy };
    },
    worldOnPage(x, y) { const b = canvas.getBoundingClientRect(); const [sx, sy] = toScreen(x, y); return { x: b.left + sx, y: b.top + sy }; },
    selected: () => [...selected].sort(),
    mapsDrawn: () => Object.values(layers).filter((l) => l.drawn).map((l) => l.info.name).sort(),
    trafficDrawn: () => trafficDrawn,
    snapshot: () => snap,
  };
})();
