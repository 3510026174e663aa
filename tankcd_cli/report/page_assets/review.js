/* tankcd review page: the map, the clock, the events and the vehicles of one replay.
   Written by hand (no library); reads the JSON in #tankcd-data (tankcd_cli/report/page.py says
   its layout) and fetches nothing. window.tankcdReview is the hook tests drive it by. */
(function () {
  "use strict";

  var STARTED = performance.now(), TIMINGS = { script: Math.round(STARTED) };
  function mark(name) { TIMINGS[name] = Math.round(performance.now() - STARTED); }
  var D = JSON.parse(document.getElementById("tankcd-data").textContent);
  mark("parsed");
  var BY_TIME = D.clock === "t";
  var SCALE = BY_TIME ? 1000 : 1;
  var OX = D.origin[0], OY = D.origin[1];
  var LEN = D.vehicle.length, WID = D.vehicle.width;

  function undelta(a, scale) {
    var out = new Float64Array(a.length), s = 0;
    for (var i = 0; i < a.length; i++) { s += a[i]; out[i] = s / scale; }
    return out;
  }
  function colourOf(k) { return "hsl(" + ((k * 137.508) % 360).toFixed(1) + ",70%,38%)"; }
  function esc(s) {
    return String(s === undefined || s === null ? "" : s).replace(/&/g, "&amp;").replace(/</g, "&lt;")
      .replace(/>/g, "&gt;").replace(/"/g, "&quot;");
  }
  function el(tag, attrs, html) {
    var e = document.createElement(tag);
    for (var k in attrs || {}) { e.setAttribute(k, attrs[k]); }
    if (html !== undefined) { e.innerHTML = html; }
    return e;
  }

  var V = D.vehicles.map(function (v, k) {
    return { name: v.name, label: v.name === "" ? "(vehicle)" : v.name, rows: v.rows, t: undelta(v.t, SCALE),
             x: undelta(v.x, 100), y: undelta(v.y, 100), h: undelta(v.h, 100), stats: v.stats, off: v.status,
             colour: colourOf(k), shown: true };
  });
  var E = D.events;
  var KIND = {};
  D.kinds.forEach(function (k) { KIND[k.name] = k; });
  var kindShown = {};
  E.forEach(function (e) { kindShown[e.kind] = true; });
  var EX = new Float64Array(E.length), EY = new Float64Array(E.length), EC = new Float64Array(E.length);
  for (var i = 0; i < E.length; i++) {
    var at = D.event_at[i];
    EX[i] = at ? at[0] / 100 : NaN;
    EY[i] = at ? at[1] / 100 : NaN;
    var c = BY_TIME ? E[i].t : E[i].step;
    EC[i] = (c === null || c === undefined) ? NaN : c;
  }
  // the events by clock (file order among equal times): the list's order and playback's stops
  var ORDER = [];
  for (i = 0; i < E.length; i++) { ORDER.push(i); }
  ORDER.sort(function (a, b) {
    var ca = isNaN(EC[a]) ? Infinity : EC[a], cb = isNaN(EC[b]) ? Infinity : EC[b];
    return ca - cb || a - b;
  });

  mark("decoded");
  var T0 = Infinity, T1 = -Infinity;
  V.forEach(function (v) { if (v.t.length) { T0 = Math.min(T0, v.t[0]); T1 = Math.max(T1, v.t[v.t.length - 1]); } });
  if (!isFinite(T0)) { T0 = 0; T1 = 0; }
  var now = T0, playing = false, selected = -1;

  /* ---------- layout ---------- */
  var nKinds = {};
  E.forEach(function (e) { nKinds[e.kind] = (nKinds[e.kind] || 0) + 1; });
  var header = el("header");
  header.appendChild(el("h1", {}, "tankcd review"));
  header.appendChild(el("span", { "class": "summary" }, esc(V.length + " vehicle" + (V.length === 1 ? "" : "s") + ", " +
    E.length + " event" + (E.length === 1 ? "" : "s") + ", " + fmtClock(T0) + " to " + fmtClock(T1))));
  document.body.appendChild(header);

  var main = el("div", { id: "main" });
  var mapbox = el("section", { id: "mapbox" });
  var canvas = el("canvas", { id: "map" });
  mapbox.appendChild(canvas);
  var legend = el("div", { id: "legend" });
  var lg = [];
  D.background.legend.forEach(function (item) { lg.push('<span class="sw" style="background:' + esc(item[1]) + '"></span>' + esc(item[0])); });
  D.kinds.forEach(function (k) {
    if (nKinds[k.name]) { lg.push('<span class="kind" style="background:' + esc(k.colour) + '"></span>' + esc(k.label)); }
  });
  legend.innerHTML = lg.join("<br>");
  mapbox.appendChild(legend);
  var scaleBox = el("div", { id: "scale" });
  mapbox.appendChild(scaleBox);
  var fitButton = el("button", { id: "fit", type: "button", title: "show the whole terrain" }, "fit");
  mapbox.appendChild(fitButton);
  main.appendChild(mapbox);

  var side = el("section", { id: "side" });
  var filters = el("div", { id: "filters" });
  var fk = ["<b>kinds</b> "];
  D.kinds.forEach(function (k) {
    if (nKinds[k.name]) {
      fk.push('<label><input type="checkbox" class="kindfilter" value="' + esc(k.name) + '" checked> ' +
        '<span class="kind" style="background:' + esc(k.colour) + '"></span>' + esc(k.name) + " (" + nKinds[k.name] + ")</label>");
    }
  });
  fk.push('<input type="text" id="vehiclefilter" placeholder="vehicles: names or parts of names, comma-separated (empty: all)">');
  filters.innerHTML = fk.join("");
  side.appendChild(filters);
  var eventbox = el("div", { id: "eventbox" });
  var rows = [];
  ORDER.forEach(function (i) {
    var e = E[i], k = KIND[e.kind] || { colour: "#000" };
    var parts = e.kind === "vehicle" ? esc(e.a_part) + " / " + esc(e.b_part) : (e.kind === "obstacle" || e.kind === "internal" ? esc(e.a) : "");
    var where = e.between ? "between rows, after " + esc(e.step) : "at row " + esc(e.step);
    var detail = [];
    if (e.closing_speed !== undefined && e.closing_speed !== null) { detail.push(e.closing_speed.toFixed(2) + " m/s"); }
    if (e.depth !== undefined && e.depth !== null) { detail.push("depth " + e.depth.toFixed(3) + " m"); }
    if (e.status !== undefined) { detail.push(esc(e.status)); }
    rows.push('<div class="ev" data-i="' + i + '"><span class="num">' + esc(fmtClock(EC[i])) + '</span><span><span class="kind" style="background:' +
      esc(k.colour) + '"></span>' + esc(e.kind) + "</span><span>" + esc(e.entity !== undefined ? e.entity : "") + "</span><span>" + esc(e.a) +
      "</span><span>" + esc(e.b) + "</span><span>" + parts + "</span><span>" + where + "</span><span>" + detail.join(", ") + "</span></div>");
  });
  // rows in blocks the browser lays out only when scrolled to (content-visibility): 34,000 rows in
  // one table cost seconds of layout before the page could draw
  var blocks = [];
  for (var b0 = 0; b0 < rows.length; b0 += 200) { blocks.push('<div class="evblock">' + rows.slice(b0, b0 + 200).join("") + "</div>"); }
  eventbox.innerHTML = '<div id="events"><div class="evhead"><span class="num">' + (BY_TIME ? "t, s" : "step") +
    "</span><span>kind</span><span>vehicle</span><span>a</span><span>b</span><span>parts</span><span>when</span><span>detail</span></div>" +
    blocks.join("") + "</div>";
  side.appendChild(eventbox);
  main.appendChild(side);
  document.body.appendChild(main);
  mark("event rows");
  var rowOf = new Array(E.length);
  Array.prototype.forEach.call(eventbox.querySelectorAll("div.ev"), function (tr) { rowOf[+tr.getAttribute("data-i")] = tr; });

  var controls = el("div", { id: "controls" });
  controls.innerHTML = '<button type="button" id="play">play</button>' +
    '<input type="range" id="slider" min="' + T0 + '" max="' + T1 + '" step="any" value="' + T0 + '">' +
    '<span id="clock"></span><label>speed <select id="speed">' +
    [0.25, 0.5, 1, 2, 5, 10, 30, 60, 120].map(function (s) { return '<option value="' + s + '"' + (s === 10 ? " selected" : "") + ">" + s + "x</option>"; }).join("") +
    '</select></label><label><input type="checkbox" id="pauseat" checked> pause at events</label>';
  document.body.appendChild(controls);
  var slider = document.getElementById("slider"), clockBox = document.getElementById("clock");
  var playButton = document.getElementById("play"), speedBox = document.getElementById("speed");
  var pauseBox = document.getElementById("pauseat");

  var kindsPresent = D.kinds.filter(function (k) { return nKinds[k.name]; });
  var vsec = el("section", { "class": "block" });
  vsec.appendChild(el("h2", {}, "vehicles"));
  var vbox = el("div", { id: "vehiclebox" });
  // a grid of divs in blocks laid out only when scrolled to, as the events: a table of 1,000 rows
  // with a checkbox each cost the page a second before it could draw
  var columns = "52px minmax(120px, 1.4fr) 124px 124px 64px 104px " + kindsPresent.map(function () { return "84px "; }).join("") +
    "150px minmax(150px, 2fr)";
  var vh = '<div id="vehicles" style="--columns: ' + columns + '"><div class="vhead"><span>show</span><span>vehicle</span><span class="num">from</span>' +
    '<span class="num">to</span><span class="num">rows</span><span class="num">distance, m</span>' +
    kindsPresent.map(function (k) { return '<span class="num">' + esc(k.name) + "</span>"; }).join("") +
    "<span>first contact</span><span>closing speeds, m/s</span></div>";
  V.forEach(function (v, k) {
    var s = v.stats, first = s.first === null ? '<span class="muted">none</span>' :
      '<a class="jump" data-event="' + s.first + '">' + esc(fmtClock(EC[s.first])) + " " + esc(E[s.first].kind) + "</a>";
    var cl = s.closing.length ? "max " + Math.max.apply(null, s.closing).toFixed(2) + " (" + s.closing.map(function (c) { return c.toFixed(2); }).slice(0, 8).join(", ") + (s.closing.length > 8 ? ", ..." : "") + ")" : "";
    if (k % 100 === 0) { vh += (k ? "</div>" : "") + '<div class="vblock">'; }
    vh += '<div class="vrow" data-v="' + k + '"><span class="vshow on" role="checkbox" aria-checked="true" title="show or hide" data-v="' + k + '"></span>' +
      '<span class="name" title="show it at the current time"><span class="sw" style="background:' + v.colour + '"></span>' + esc(v.label) + "</span>" +
      '<span class="num">' + esc(fmtClock(s.from)) + '</span><span class="num">' + esc(fmtClock(s.to)) + '</span><span class="num">' + v.rows +
      '</span><span class="num">' + s.distance.toFixed(1) + "</span>" +
      kindsPresent.map(function (kd) { return '<span class="num">' + (s.contacts[kd.name] || 0) + "</span>"; }).join("") +
      "<span>" + first + "</span><span>" + cl + "</span></div>";
  });
  vbox.innerHTML = vh + (V.length ? "</div>" : "") + "</div>";
  vsec.appendChild(vbox);
  document.body.appendChild(vsec);

  var P = D.provenance, tol = D.tolerance;
  var psec = el("section", { "class": "block", id: "provenance" });
  var ph = "<h2>provenance</h2><p>tankcd " + esc(P.tankcd_version || "(version not recorded)") +
    ". Tracks drawn and played within " + tol.position_m + " m of the poses' positions and " + tol.heading_deg +
    " deg of their headings at every time (" + tol.rows + " rows kept as " + tol.vertices + " vertices); every event kept.</p>" +
    "<table><thead><tr><th>role</th><th>path</th><th>SHA-256</th></tr></thead><tbody>";
  P.sources.forEach(function (s) { ph += "<tr><td>" + esc(s.role) + "</td><td>" + esc(s.path) + "</td><td><code>" + esc(s.sha256 || "(not hashed)") + "</code></td></tr>"; });
  ph += "</tbody></table><h2>settings</h2><pre>" + esc(JSON.stringify(P.settings, null, 1)) + "</pre>";
  ph += "<details><summary>CRS</summary><pre>" + esc(P.crs_wkt || "(none: local coordinates)") + "</pre></details>";
  psec.innerHTML = ph;
  document.body.appendChild(psec);

  /* ---------- the map ---------- */
  mark("tables");
  var ctx = canvas.getContext("2d");
  var layer = document.createElement("canvas"), lctx = layer.getContext("2d");
  var img = new Image(), imgReady = false;
  var ext = D.background.extent;
  var view = { cx: (ext[0] + ext[1]) / 2, cy: (ext[2] + ext[3]) / 2, s: 1 };
  var dpr = 1, cw = 1, chh = 1, layerDirty = true, frameQueued = false;

  // what fit shows: the terrain, and any track that strays beyond it
  var box = ext.slice();
  V.forEach(function (v) {
    for (var i = 0; i < v.x.length; i++) {
      if (v.x[i] < box[0]) { box[0] = v.x[i]; } else if (v.x[i] > box[1]) { box[1] = v.x[i]; }
      if (v.y[i] < box[2]) { box[2] = v.y[i]; } else if (v.y[i] > box[3]) { box[3] = v.y[i]; }
    }
  });
  function fit() {
    var w = Math.max(box[1] - box[0], 1), h = Math.max(box[3] - box[2], 1);
    view.cx = (box[0] + box[1]) / 2; view.cy = (box[2] + box[3]) / 2;
    view.s = Math.min(cw / w, chh / h) * 0.96;
    layerDirty = true; redraw();
  }
  function resize() {
    dpr = window.devicePixelRatio || 1;
    cw = Math.max(canvas.clientWidth, 1); chh = Math.max(canvas.clientHeight, 1);
    canvas.width = Math.round(cw * dpr); canvas.height = Math.round(chh * dpr);
    layer.width = canvas.width; layer.height = canvas.height;
    layerDirty = true;
  }
  function sx(x) { return cw / 2 + (x - view.cx) * view.s; }
  function sy(y) { return chh / 2 - (y - view.cy) * view.s; }

  function eventShown(i) {
    if (!kindShown[E[i].kind]) { return false; }
    var p = D.event_parties[i];
    if (!p.length) { return true; }
    for (var j = 0; j < p.length; j++) { if (V[p[j]].shown) { return true; } }
    return false;
  }

  function drawLayer() {
    lctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    lctx.clearRect(0, 0, cw, chh);
    if (imgReady) {
      lctx.imageSmoothingEnabled = false;
      lctx.drawImage(img, sx(ext[0]), sy(ext[3]), (ext[1] - ext[0]) * view.s, (ext[3] - ext[2]) * view.s);
    }
    lctx.lineWidth = 1.5;
    lctx.lineJoin = "round";
    V.forEach(function (v) {
      if (!v.shown || v.x.length === 0) { return; }
      lctx.strokeStyle = v.colour;
      lctx.beginPath();
      var lx = sx(v.x[0]), ly = sy(v.y[0]);
      lctx.moveTo(lx, ly);
      for (var i = 1; i < v.x.length; i++) {
        var px = sx(v.x[i]), py = sy(v.y[i]);
        // vertices closer than half a pixel to the last drawn add nothing to the picture
        if (Math.abs(px - lx) + Math.abs(py - ly) > 0.5 || i === v.x.length - 1) { lctx.lineTo(px, py); lx = px; ly = py; }
      }
      lctx.stroke();
    });
    // one path per kind: a fill and a stroke per kind, not per event (34,000 events)
    lctx.strokeStyle = "#fff";
    lctx.lineWidth = 1;
    D.kinds.forEach(function (kd) {
      if (!nKinds[kd.name] || !kindShown[kd.name]) { return; }
      lctx.fillStyle = kd.colour;
      lctx.beginPath();
      for (var i = 0; i < E.length; i++) {
        if (E[i].kind !== kd.name || isNaN(EX[i]) || !eventShown(i)) { continue; }
        var ex = sx(EX[i]), ey = sy(EY[i]);
        if (ex < -5 || ey < -5 || ex > cw + 5 || ey > chh + 5) { continue; }
        lctx.moveTo(ex + 3.5, ey);
        lctx.arc(ex, ey, 3.5, 0, 2 * Math.PI);
      }
      lctx.stroke(); lctx.fill();  // every halo first, then every dot over them
    });
    layerDirty = false;
    var metres = 100 / view.s, p10 = Math.pow(10, Math.floor(Math.log10(metres)));
    var nice = [1, 2, 5, 10].map(function (m) { return m * p10; }).filter(function (m) { return m <= metres; }).pop() || p10;
    scaleBox.innerHTML = '<span style="display:inline-block;height:4px;background:#212121;vertical-align:middle;width:' +
      (nice * view.s).toFixed(0) + 'px"></span> ' + nice + " m";
  }

  // position and heading of vehicle v at clock value c: linear between its kept vertices (null: absent)
  function poseAt(v, c) {
    var t = v.t, n = t.length;
    if (!n || c < t[0] || c > t[n - 1]) { return null; }
    var lo = 0, hi = n - 1;
    while (hi - lo > 1) { var mid = (lo + hi) >> 1; if (t[mid] <= c) { lo = mid; } else { hi = mid; } }
    var dt = t[hi] - t[lo], u = dt > 0 ? (c - t[lo]) / dt : 0;
    if (u > 1) { u = 1; }
    var row = c >= t[hi] ? hi : lo, status = 0;  // the status of the last row at or before c
    var a = 0, b = v.off.length;  // the last change at or before the row
    while (a < b) { var m = (a + b) >> 1; if (v.off[m][0] <= row) { a = m + 1; } else { b = m; } }
    if (a > 0) { status = v.off[a - 1][1]; }
    return [v.x[lo] + u * (v.x[hi] - v.x[lo]), v.y[lo] + u * (v.y[hi] - v.y[lo]), v.h[lo] + u * (v.h[hi] - v.h[lo]), status];
  }

  function draw() {
    frameQueued = false;
    if (layerDirty) { drawLayer(); }
    if (TIMINGS.first_frame === undefined) { TIMINGS.first_frame = Math.round(performance.now()); }  // since navigation
    ctx.setTransform(1, 0, 0, 1, 0, 0);
    ctx.clearRect(0, 0, canvas.width, canvas.height);
    ctx.drawImage(layer, 0, 0);
    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    var labels = V.length <= 40;
    V.forEach(function (v) {
      if (!v.shown) { return; }
      var p = poseAt(v, now);
      if (!p) { return; }
      var x = sx(p[0]), y = sy(p[1]), a = -p[2] * Math.PI / 180;
      var l = Math.max(LEN * view.s, 6), w = Math.max(WID * view.s, 3);
      ctx.save();
      ctx.translate(x, y); ctx.rotate(a);
      // off the terrain (status 2) hollow and dashed, partly off (1) paler
      ctx.fillStyle = v.colour; ctx.globalAlpha = p[3] === 2 ? 0 : (p[3] === 1 ? 0.25 : 0.55);
      ctx.fillRect(-l / 2, -w / 2, l, w);
      ctx.globalAlpha = 1; ctx.strokeStyle = "#111"; ctx.lineWidth = 1;
      if (p[3]) { ctx.setLineDash([3, 2]); }
      ctx.strokeRect(-l / 2, -w / 2, l, w);
      ctx.setLineDash([]);
      ctx.beginPath(); ctx.moveTo(0, 0); ctx.lineTo(l / 2 + 6, 0); ctx.stroke();  // heading
      ctx.restore();
      if (labels) { ctx.fillStyle = "#111"; ctx.font = "11px sans-serif"; ctx.fillText(v.label, x + l / 2 + 4, y - 4); }
    });
    if (selected >= 0 && !isNaN(EX[selected])) {
      ctx.strokeStyle = "#0d47a1"; ctx.lineWidth = 2.5;
      ctx.beginPath(); ctx.arc(sx(EX[selected]), sy(EY[selected]), 9, 0, 2 * Math.PI); ctx.stroke();
    }
    clockBox.textContent = (BY_TIME ? "t = " : "step ") + fmtClock(now) + " / " + fmtClock(T1);
  }
  function redraw() { if (!frameQueued) { frameQueued = true; window.requestAnimationFrame(draw); } }

  function fmtClock(c) {
    if (c === null || c === undefined || isNaN(c)) { return ""; }
    if (!BY_TIME) { return String(Math.round(c)); }
    var m = Math.floor(c / 60), s = c - 60 * m;
    return c.toFixed(3) + (c >= 60 ? " (" + m + ":" + (s < 10 ? "0" : "") + s.toFixed(1) + ")" : "");
  }

  /* ---------- the clock ---------- */
  function setTime(c) {
    now = Math.min(Math.max(+c, T0), T1);
    slider.value = now;
    redraw();
  }
  function selectEvent(i) {
    if (i < 0 || i >= E.length) { return; }
    if (selected >= 0 && rowOf[selected]) { rowOf[selected].classList.remove("selected"); }
    selected = i;
    var row = rowOf[i];
    if (row) {
      row.classList.add("selected");
      var box = eventbox.getBoundingClientRect(), r = row.getBoundingClientRect();
      if (r.top < box.top + 20 || r.bottom > box.bottom) { eventbox.scrollTop += r.top - box.top - box.height / 3; }
    }
    if (!isNaN(EX[i])) {
      view.cx = EX[i]; view.cy = EY[i];
      view.s = Math.max(view.s, 40 / LEN);  // close enough to see the footprints meet
      layerDirty = true;
    }
    if (!isNaN(EC[i])) { setTime(EC[i]); } else { redraw(); }
  }

  var lastFrame = null;
  function tick(stamp) {
    if (!playing) { lastFrame = null; return; }
    if (lastFrame !== null) {
      var step = (stamp - lastFrame) / 1000 * parseFloat(speedBox.value) * (BY_TIME ? 1 : 10);
      var next = Math.min(now + step, T1), stop = -1;
      if (pauseBox.checked) {
        // the first shown event after now, up to next (ORDER is by clock)
        var lo = 0, hi = ORDER.length;
        while (lo < hi) { var mid = (lo + hi) >> 1; if (EC[ORDER[mid]] <= now) { lo = mid + 1; } else { hi = mid; } }
        for (var j = lo; j < ORDER.length && EC[ORDER[j]] <= next; j++) {
          if (eventShown(ORDER[j])) { stop = ORDER[j]; break; }
        }
      }
      if (stop >= 0) { setPlaying(false); selectEvent(stop); return; }
      setTime(next);
      if (next >= T1) { setPlaying(false); return; }
    }
    lastFrame = stamp;
    window.requestAnimationFrame(tick);
  }
  function setPlaying(on) {
    playing = on;
    playButton.textContent = on ? "pause" : "play";
    if (on) { if (now >= T1) { setTime(T0); } window.requestAnimationFrame(tick); }
  }

  /* ---------- input ---------- */
  playButton.addEventListener("click", function () { setPlaying(!playing); });
  slider.addEventListener("input", function () { setTime(parseFloat(slider.value)); });
  eventbox.addEventListener("click", function (ev) {
    var tr = ev.target.closest("div.ev[data-i]");
    if (tr) { setPlaying(false); selectEvent(+tr.getAttribute("data-i")); }
  });
  vbox.addEventListener("click", function (ev) {
    var a = ev.target.closest("a.jump");
    if (a) { setPlaying(false); selectEvent(+a.getAttribute("data-event")); return; }
    var show = ev.target.closest("span.vshow");
    if (show) { showVehicle(+show.getAttribute("data-v"), !V[+show.getAttribute("data-v")].shown); applyFilters(); return; }
    var name = ev.target.closest("span.name");
    if (name) {
      var v = V[+name.parentNode.getAttribute("data-v")], p = poseAt(v, now) || (v.x.length ? [v.x[0], v.y[0]] : null);
      if (p) { view.cx = p[0]; view.cy = p[1]; layerDirty = true; redraw(); }
    }
  });
  function showVehicle(k, on) {
    V[k].shown = on;
    var box = vbox.querySelector('span.vshow[data-v="' + k + '"]');
    if (box) { box.classList.toggle("on", on); box.setAttribute("aria-checked", on ? "true" : "false"); }
  }
  filters.addEventListener("change", function (ev) {
    if (ev.target.classList.contains("kindfilter")) { kindShown[ev.target.value] = ev.target.checked; applyFilters(); }
  });
  document.getElementById("vehiclefilter").addEventListener("input", function (ev) {
    var words = ev.target.value.split(",").map(function (w) { return w.trim().toLowerCase(); }).filter(function (w) { return w; });
    V.forEach(function (v, k) {
      showVehicle(k, !words.length || words.some(function (w) { return v.name.toLowerCase().indexOf(w) >= 0; }));
    });
    applyFilters();
  });
  function applyFilters() {
    for (var i = 0; i < E.length; i++) { if (rowOf[i]) { rowOf[i].hidden = !eventShown(i); } }
    layerDirty = true; redraw();
  }

  var drag = null;
  canvas.addEventListener("mousedown", function (ev) { drag = { x: ev.clientX, y: ev.clientY, cx: view.cx, cy: view.cy }; canvas.classList.add("dragging"); });
  window.addEventListener("mouseup", function () { drag = null; canvas.classList.remove("dragging"); });
  window.addEventListener("mousemove", function (ev) {
    if (!drag) { return; }
    view.cx = drag.cx - (ev.clientX - drag.x) / view.s;
    view.cy = drag.cy + (ev.clientY - drag.y) / view.s;
    layerDirty = true; redraw();
  });
  canvas.addEventListener("wheel", function (ev) {
    ev.preventDefault();
    var r = canvas.getBoundingClientRect(), mx = ev.clientX - r.left, my = ev.clientY - r.top;
    var wx = view.cx + (mx - cw / 2) / view.s, wy = view.cy - (my - chh / 2) / view.s;
    view.s *= Math.exp(-ev.deltaY * 0.0015);
    view.cx = wx - (mx - cw / 2) / view.s; view.cy = wy + (my - chh / 2) / view.s;
    layerDirty = true; redraw();
  }, { passive: false });
  fitButton.addEventListener("click", fit);
  window.addEventListener("resize", function () { resize(); redraw(); });

  img.onload = function () { imgReady = true; layerDirty = true; redraw(); };
  img.src = D.background.png;
  resize();
  fit();
  setTime(T0);

  mark("drawn");
  window.tankcdReview = {
    timings: TIMINGS,
    vehicles: V.map(function (v) { return v.name; }),
    events: E.length,
    setTime: function (c) { setTime(c); draw(); },
    time: function () { return now; },
    positionOf: function (name) {
      for (var k = 0; k < V.length; k++) {
        if (V[k].name === name) { var p = poseAt(V[k], now); return p ? [p[0] + OX, p[1] + OY] : null; }
      }
      return null;
    },
    statusOf: function (name) {
      for (var k = 0; k < V.length; k++) { if (V[k].name === name) { var p = poseAt(V[k], now); return p ? ["ok", "partly_off", "off"][p[3]] : null; } }
      return null;
    },
    headingOf: function (name) {
      for (var k = 0; k < V.length; k++) { if (V[k].name === name) { var p = poseAt(V[k], now); return p ? p[2] : null; } }
      return null;
    },
    selectEvent: function (i) { selectEvent(i); draw(); },
    ready: true
  };
})();
