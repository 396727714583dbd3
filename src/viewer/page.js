// The mdas page: src/viewer/mod.rs writes it into index.html with the
// record (#mdas-record), a manifest (#mdas-page) and the data (#mdas-image-N:
// linear RGB as little-endian half floats in base64; #mdas-map-N: map PNGs;
// #mdas-plot: sweep.svg). Standard DOM and canvas 2D only; no network.
//
// Test hook: window.mdasView = {ready, error, loadMs, state(),
// filmToClient(x, y)}. The canvas #view draws film pixel (x, y) over the
// CSS pixels left + ox + [x, x + 1)·zoom × top + oy + [y, y + 1)·zoom of
// its bounding rectangle, with (ox, oy) and zoom from state();
// filmToClient(x, y) is that square's centre in client coordinates.
(function () {
  'use strict';

  const hook = { ready: false, error: null, loadMs: null };
  window.mdasView = hook;

  // ---------- small helpers ----------
  function el(tag, attrs, ...children) {
    const e = document.createElement(tag);
    for (const [k, v] of Object.entries(attrs || {})) {
      if (v === undefined || v === null || v === false) continue;
      if (k === 'class') e.className = v;
      else if (k.startsWith('on')) e.addEventListener(k.slice(2), v);
      else e.setAttribute(k, v === true ? '' : v);
    }
    for (const c of children.flat()) {
      if (c === undefined || c === null) continue;
      e.append(c instanceof Node ? c : String(c));
    }
    return e;
  }
  const text = (id) => {
    const e = document.getElementById(id);
    return e ? e.textContent : null;
  };
  function num(x) {
    if (x === undefined || x === null || (typeof x === 'number' && isNaN(x))) return '—';
    if (typeof x !== 'number') return String(x);
    if (!isFinite(x)) return x > 0 ? '∞' : '−∞';
    if (Number.isInteger(x) && Math.abs(x) < 1e7) return String(x);
    const a = Math.abs(x);
    if (a !== 0 && (a < 1e-3 || a >= 1e5)) return x.toExponential(3);
    return x.toPrecision(4);
  }
  const interval = (ci) => (Array.isArray(ci) && ci.length === 2 ? `[${num(ci[0])}, ${num(ci[1])}]` : '');
  const withCi = (x, ci) => (x === undefined || x === null ? '—' : `${num(x)} ${interval(ci)}`.trim());
  const pct = (x) => (typeof x === 'number' ? `${(100 * x).toFixed(2)}%` : '—');
  // Relative bias per channel with its interval, one channel per line.
  function biasCell(b, ci) {
    if (!Array.isArray(b)) return '—';
    return el('span', {}, b.flatMap((x, c) => [c ? el('br') : null,
      `${'RGB'[c]} ${pct(x)}${Array.isArray(ci) ? ` [${pct(ci[c][0])}, ${pct(ci[c][1])}]` : ''}`]));
  }
  // Parts a merged record was joined from (`mdas merge`).
  function partList(parts) {
    if (!Array.isArray(parts) || !parts.length) return [];
    return [['merged from', `${parts.length} parts`],
      ...parts.map((q) => [`part ${q.part}`, `${(q.command_line || []).map(shellWord).join(' ')} · ${q.timestamp_utc || ''}`])];
  }
  function section(title, ...children) {
    return el('section', {}, el('h2', {}, title), ...children);
  }
  function status(message, isError) {
    const s = document.getElementById('status');
    s.textContent = message;
    s.className = isError ? 'error' : '';
  }

  // A table whose columns sort on a click of their header. A column is
  // {h: header, v: row => value (number, string or null), f: optional
  // (value, row) => text, text: true for a left-aligned text column}.
  function sortable(columns, rows, options) {
    const opts = options || {};
    const table = el('table', { class: 'sortable' });
    const body = el('tbody');
    let key = -1;
    let dir = 1;
    const heads = columns.map((c, i) =>
      el('th', { class: 'sort' + (c.text ? ' text' : ''), title: 'click to sort', onclick: () => sortBy(i) }, c.h));
    table.append(el('thead', {}, el('tr', {}, heads)), body);
    function fill() {
      const order = rows.map((r, i) => i);
      if (key >= 0) {
        const v = (i) => columns[key].v(rows[i]);
        order.sort((a, b) => {
          const x = v(a);
          const y = v(b);
          const xn = x === null || x === undefined || (typeof x === 'number' && isNaN(x));
          const yn = y === null || y === undefined || (typeof y === 'number' && isNaN(y));
          if (xn || yn) return xn === yn ? a - b : xn ? 1 : -1;
          if (typeof x === 'number' && typeof y === 'number') return dir * (x - y) || a - b;
          return dir * String(x).localeCompare(String(y)) || a - b;
        });
      }
      body.replaceChildren(...order.map((i) => {
        const r = rows[i];
        const tr = el('tr', { class: opts.pick ? 'pick' : null },
          columns.map((c) => el('td', { class: c.text ? 'text' : null }, c.f ? c.f(c.v(r), r) : num(c.v(r)))));
        if (opts.pick) tr.addEventListener('click', () => opts.pick(r, i));
        if (opts.decorate) opts.decorate(tr, r, i);
        return tr;
      }));
      heads.forEach((h, i) => { h.dataset.sorted = i === key ? (dir > 0 ? 'up' : 'down') : ''; });
    }
    function sortBy(i) {
      dir = key === i ? -dir : 1;
      key = i;
      fill();
    }
    table.refresh = fill;
    fill();
    return el('div', { class: 'scroll' }, table);
  }

  function provenance(p, extra) {
    const rows = [];
    const add = (k, v) => {
      if (v !== undefined && v !== null && v !== '') rows.push(el('dt', {}, k), el('dd', {}, v));
    };
    if (p) {
      add('command line', (p.command_line || []).map(shellWord).join(' '));
      add('scene SHA-256', p.scene_sha256);
      add('integrand', p.integrand !== undefined ? `${p.integrand} (${p.dims} dimensions)` : null);
      add('version', p.version);
      add('git commit', p.git_commit);
      add('adapter', p.adapter);
      add('driver', [p.driver, p.driver_info].filter(Boolean).join(' · '));
      add('time (UTC)', p.timestamp_utc);
      if (p.mdas) add('MDAS parameters', JSON.stringify(p.mdas));
    } else {
      rows.push(el('dt', {}, 'provenance'), el('dd', {}, 'none in the record'));
    }
    for (const [k, v] of extra || []) add(k, v);
    return el('dl', {}, rows);
  }
  function shellWord(w) {
    return /^[\w@%+=:,./-]+$/.test(w) ? w : `'${String(w).replace(/'/g, `'\\''`)}'`;
  }
  function keyList(keys, note) {
    return section('Keyboard and mouse',
      el('table', {}, el('tbody', {}, keys.map((k) =>
        el('tr', {}, el('td', {}, ...k.label.split(' ').map((w) => (w === '/' || w === '…' ? ` ${w} ` : el('kbd', {}, w)))),
          el('td', { class: 'text' }, k.doc))))),
      note ? el('p', { class: 'dim' }, note) : null);
  }
  function flagList(flags) {
    const f = flags.filter(Boolean);
    return f.length ? el('ul', { class: 'warn' }, f.map((x) => el('li', {}, x))) : null;
  }

  // ---------- pixel data ----------
  const HALF = new Float32Array(65536);
  for (let h = 0; h < 65536; h++) {
    const s = h & 0x8000 ? -1 : 1;
    const e = (h >> 10) & 31;
    const m = h & 1023;
    HALF[h] = e === 0 ? s * m * 2 ** -24 : e === 31 ? (m ? NaN : s * Infinity) : s * (1 + m / 1024) * 2 ** (e - 15);
  }
  const LITTLE = new Uint8Array(new Uint16Array([1]).buffer)[0] === 1;
  function unbase64(t) {
    if (typeof Uint8Array.fromBase64 === 'function') return Uint8Array.fromBase64(t);
    const bin = atob(t);
    const out = new Uint8Array(bin.length);
    for (let i = 0; i < bin.length; i++) out[i] = bin.charCodeAt(i);
    return out;
  }
  function halves(t) {
    const bytes = unbase64(t);
    if (!LITTLE) for (let i = 0; i + 1 < bytes.length; i += 2) [bytes[i], bytes[i + 1]] = [bytes[i + 1], bytes[i]];
    return new Uint16Array(bytes.buffer, bytes.byteOffset, bytes.length >> 1);
  }
  // Half bits → 8-bit sRGB of clamp(2^stops · value): NaN and negatives 0.
  const luts = new Map();
  function lut(stops) {
    let l = luts.get(stops);
    if (l) return l;
    l = new Uint8Array(65536);
    const k = 2 ** stops;
    for (let h = 0; h < 65536; h++) {
      const v = HALF[h] * k;
      if (!(v > 0)) continue;
      const c = v >= 1 ? 1 : v <= 0.0031308 ? 12.92 * v : 1.055 * Math.pow(v, 1 / 2.4) - 0.055;
      l[h] = Math.round(c * 255);
    }
    if (luts.size > 8) luts.clear();
    luts.set(stops, l);
    return l;
  }

  // ---------- the comparison viewer ----------
  function comparison(record, page) {
    const [W, H] = page.film;
    const images = page.images.map((m, i) => ({
      ...m, index: i, halves: halves(text(`mdas-image-${i}`)), canvas: null, stops: null,
      report: m.method === null ? null : record.methods[m.method], maps: {}, mapFiles: {},
    }));
    const layers = [
      { key: 'relmse', k: 'e', name: 'RelMSE', range: record.maps && record.maps.relmse_range, scale: 'log' },
      { key: 'flip', k: 'f', name: 'FLIP', range: record.maps && record.maps.flip_range, scale: 'linear' },
      { key: 'density', k: 'd', name: 'density', range: record.maps && record.maps.density_range, scale: 'log', unit: 'spp' },
    ].filter((l) => page.maps.some((m) => m.layer === l.key));
    const loads = page.maps.map((m, j) => {
      const img = new Image();
      img.src = `data:image/png;base64,${text(`mdas-map-${j}`)}`;
      images[m.image].maps[m.layer] = img;
      images[m.image].mapFiles[m.layer] = m.file;
      return img.decode();
    });

    const st = { image: 0, layer: null, stops: 0, zoom: 1, ox: 0, oy: 0, opacity: 1, pinned: null, cursor: null };
    const film = document.createElement('canvas');
    film.width = W;
    film.height = H;
    const filmCtx = film.getContext('2d');
    const pixels = filmCtx.createImageData(W, H);

    // The image's 8-bit sRGB at the current exposure, cached per image.
    function source(img) {
      if (img.canvas && img.stops === st.stops) return img.canvas;
      const l = lut(st.stops);
      const d = pixels.data;
      const hv = img.halves;
      for (let i = 0, j = 0, k = 0, n = W * H; i < n; i++, j += 4, k += 3) {
        d[j] = l[hv[k]];
        d[j + 1] = l[hv[k + 1]];
        d[j + 2] = l[hv[k + 2]];
        d[j + 3] = 255;
      }
      if (!img.canvas) {
        img.canvas = document.createElement('canvas');
        img.canvas.width = W;
        img.canvas.height = H;
      }
      img.canvas.getContext('2d').putImageData(pixels, 0, 0);
      img.stops = st.stops;
      return img.canvas;
    }

    // ----- elements -----
    const canvas = el('canvas', { id: 'view' });
    const badge = el('div', { id: 'badge' });
    const viewport = el('div', { id: 'viewport' }, canvas, badge);
    const imageButtons = images.map((img, i) =>
      el('button', { onclick: () => show(i), title: img.file }, img.label, el('kbd', {}, i === 0 ? 'r' : i <= 9 ? String(i) : '')));
    const layerButtons = [el('button', { onclick: () => setLayer(null) }, 'none', el('kbd', {}, 'n'))].concat(
      layers.map((l) => el('button', { onclick: () => setLayer(l.key) }, l.name, el('kbd', {}, l.k))));
    const slider = el('input', { type: 'range', min: -12, max: 12, step: 0.1, value: 0, 'aria-label': 'exposure in stops' });
    slider.addEventListener('input', () => setStops(Number(slider.value)));
    const stopsText = el('span', { class: 'dim' });
    const opacity = el('input', { type: 'range', min: 0, max: 1, step: 0.05, value: 1, 'aria-label': 'map opacity' });
    opacity.addEventListener('input', () => { st.opacity = Number(opacity.value); draw(); });
    const zoomText = el('span', { class: 'dim' });
    const legend = el('div', { class: 'legend' });
    const inspector = el('tbody');
    const inspectorHead = el('div', { class: 'dim' });

    // ----- view -----
    let dpr = window.devicePixelRatio || 1;
    const snap = (v) => Math.round(v * dpr) / dpr;
    function fitZoom() {
      const r = viewport.getBoundingClientRect();
      return Math.min(r.width / W, r.height / H) || 1;
    }
    function fit() {
      const r = viewport.getBoundingClientRect();
      st.zoom = fitZoom();
      st.ox = snap((r.width - W * st.zoom) / 2);
      st.oy = snap((r.height - H * st.zoom) / 2);
      draw();
    }
    // Zoom to `z` keeping the film point under canvas point (cx, cy) fixed.
    function zoomTo(z, cx, cy) {
      const r = viewport.getBoundingClientRect();
      if (cx === undefined) { cx = r.width / 2; cy = r.height / 2; }
      const lo = Math.min(fitZoom(), 1) / 8;
      z = Math.min(Math.max(z, lo), 512);
      const fx = (cx - st.ox) / st.zoom;
      const fy = (cy - st.oy) / st.zoom;
      st.zoom = z;
      st.ox = snap(cx - fx * z);
      st.oy = snap(cy - fy * z);
      draw();
    }
    // Zoom steps are powers of two: every pixel then covers whole screen pixels.
    const step = (dir, cx, cy) => zoomTo(2 ** (dir > 0 ? Math.floor(Math.log2(st.zoom) + 1e-9) + 1 : Math.ceil(Math.log2(st.zoom) - 1e-9) - 1), cx, cy);
    function pan(dx, dy) {
      st.ox = snap(st.ox + dx);
      st.oy = snap(st.oy + dy);
      draw();
    }
    function resize() {
      dpr = window.devicePixelRatio || 1;
      const r = viewport.getBoundingClientRect();
      canvas.width = Math.max(1, Math.round(r.width * dpr));
      canvas.height = Math.max(1, Math.round(r.height * dpr));
    }
    function currentMap() {
      return st.layer ? images[st.image].maps[st.layer] || null : null;
    }
    function draw() {
      const ctx = canvas.getContext('2d');
      ctx.setTransform(1, 0, 0, 1, 0, 0);
      ctx.fillStyle = '#0c0c0c';
      ctx.fillRect(0, 0, canvas.width, canvas.height);
      ctx.imageSmoothingEnabled = false;
      ctx.setTransform(st.zoom * dpr, 0, 0, st.zoom * dpr, st.ox * dpr, st.oy * dpr);
      const img = images[st.image];
      const map = currentMap();
      if (!map || st.opacity < 1) ctx.drawImage(source(img), 0, 0);
      if (map) {
        ctx.globalAlpha = st.opacity;
        ctx.drawImage(map, 0, 0);
        ctx.globalAlpha = 1;
      }
      ctx.setTransform(1, 0, 0, 1, 0, 0);
      panel();
    }
    function panel() {
      const img = images[st.image];
      const layer = layers.find((l) => l.key === st.layer);
      const map = currentMap();
      badge.textContent = `${img.label}${map ? ` · ${layer.name} map` : layer ? ` · no ${layer.name} map` : ''}` +
        ` · ${st.stops >= 0 ? '+' : ''}${st.stops.toFixed(1)} EV`;
      imageButtons.forEach((b, i) => b.classList.toggle('on', i === st.image));
      layerButtons.forEach((b, i) => b.classList.toggle('on', i === 0 ? !st.layer : layers[i - 1].key === st.layer));
      stopsText.textContent = `${st.stops >= 0 ? '+' : ''}${st.stops.toFixed(1)} stops`;
      zoomText.textContent = `zoom ${st.zoom >= 1 ? num(st.zoom) + '×' : '1/' + num(1 / st.zoom)}`;
      legend.replaceChildren();
      if (layer) {
        const stops = page.viridis.map((c, i) => `rgb(${c.join(',')}) ${(100 * i) / (page.viridis.length - 1)}%`);
        const r = layer.range || [];
        legend.append(`${layer.name}${layer.unit ? ` (${layer.unit})` : ''}, ${layer.scale} scale`, el('span', {}, num(r[0])),
          el('div', { class: 'bar', style: `background: linear-gradient(to right, ${stops.join(', ')})` }), el('span', {}, num(r[1])),
          map ? '' : el('span', { class: 'warn' }, `(none for ${img.label})`));
      }
      for (const tr of document.querySelectorAll('tr[data-image]')) tr.classList.toggle('current', Number(tr.dataset.image) === st.image);
      inspect();
    }
    function inspect() {
      const p = st.pinned || st.cursor;
      if (!p) {
        inspectorHead.textContent = 'move over the image (click pins a pixel)';
        inspector.replaceChildren();
        return;
      }
      inspectorHead.textContent = `film pixel (${p[0]}, ${p[1]})${st.pinned ? ' · pinned (click to release)' : ''}`;
      const i3 = 3 * (p[1] * W + p[0]);
      inspector.replaceChildren(...images.map((img, i) => el('tr', { class: i === st.image ? 'current' : null },
        el('td', {}, img.label), [0, 1, 2].map((c) => el('td', {}, num(HALF[img.halves[i3 + c]]))))));
    }
    function filmAt(clientX, clientY) {
      const r = canvas.getBoundingClientRect();
      const x = Math.floor((clientX - r.left - st.ox) / st.zoom);
      const y = Math.floor((clientY - r.top - st.oy) / st.zoom);
      return x >= 0 && y >= 0 && x < W && y < H ? [x, y] : null;
    }
    function show(i) {
      st.image = (i + images.length) % images.length;
      draw();
    }
    function setLayer(key) {
      st.layer = key;
      draw();
    }
    function setStops(s) {
      st.stops = Math.round(Math.min(Math.max(s, -24), 24) * 10) / 10;
      slider.value = st.stops;
      draw();
    }
    function cycleLayer(dir) {
      const keys = [null, ...layers.map((l) => l.key)];
      setLayer(keys[(keys.indexOf(st.layer) + dir + keys.length) % keys.length]);
    }

    // ----- input -----
    const panStep = () => viewport.getBoundingClientRect().width / 8;
    const keys = [
      { label: 'r', doc: 'the reference', test: (e) => e.key === 'r', run: () => show(0) },
      { label: '1 … 9', doc: 'method 1 … 9 (the rows of the table below)', test: (e) => /^[1-9]$/.test(e.key), run: (e) => { if (Number(e.key) < images.length) show(Number(e.key)); } },
      { label: '← / →', doc: 'previous / next image', test: (e) => !e.shiftKey && (e.key === 'ArrowLeft' || e.key === 'ArrowRight'), run: (e) => show(st.image + (e.key === 'ArrowRight' ? 1 : -1)) },
      { label: '+ / -', doc: 'zoom in / out (about the cursor when it is over the image); also the mouse wheel', test: (e) => ['+', '=', '-', '_'].includes(e.key), run: (e) => { const c = st.cursorCss; step(e.key === '+' || e.key === '=' ? 1 : -1, c && c[0], c && c[1]); } },
      { label: '0', doc: 'fit the image to the view', test: (e) => e.key === '0', run: () => fit() },
      { label: 'p', doc: 'one film pixel per screen pixel', test: (e) => e.key === 'p', run: () => { const c = st.cursorCss; zoomTo(1 / dpr, c && c[0], c && c[1]); } },
      { label: 'Shift+← Shift+↑ Shift+→ Shift+↓', doc: 'pan (or drag with the mouse)', test: (e) => e.shiftKey && e.key.startsWith('Arrow'), run: (e) => pan(...{ ArrowLeft: [1, 0], ArrowRight: [-1, 0], ArrowUp: [0, 1], ArrowDown: [0, -1] }[e.key].map((d) => d * panStep())) },
      { label: '[ / ]', doc: 'exposure −½ / +½ stop (also the slider)', test: (e) => e.key === '[' || e.key === ']', run: (e) => setStops(st.stops + (e.key === ']' ? 0.5 : -0.5)) },
      { label: '\\', doc: 'exposure back to 0 stops', test: (e) => e.key === '\\', run: () => setStops(0) },
      ...layers.map((l) => ({ label: l.k, doc: `${l.name} map layer on / off (over the image it belongs to)`, test: (e) => e.key === l.k, run: () => setLayer(st.layer === l.key ? null : l.key) })),
      { label: 'm', doc: 'next map layer (Shift+M: previous)', test: (e) => e.key === 'm' || e.key === 'M', run: (e) => cycleLayer(e.key === 'M' ? -1 : 1) },
      { label: 'n / Esc', doc: 'no map layer; unpin the inspector', test: (e) => e.key === 'n' || e.key === 'Escape', run: () => { st.pinned = null; setLayer(null); } },
      { label: 'o', doc: 'map layer opacity 100 % / 50 %', test: (e) => e.key === 'o', run: () => { st.opacity = st.opacity === 1 ? 0.5 : 1; opacity.value = st.opacity; draw(); } },
    ];
    document.addEventListener('keydown', (e) => {
      if (e.ctrlKey || e.metaKey || e.altKey) return;
      // A focused slider keeps its own keys (arrows, Home, End, Page Up/Down).
      if (e.target instanceof HTMLInputElement && (e.target.type !== 'range' || /^(Arrow|Home|End|Page)/.test(e.key))) return;
      const k = keys.find((x) => x.test(e));
      if (!k) return;
      e.preventDefault();
      k.run(e);
    });
    let wheel = 0;
    viewport.addEventListener('wheel', (e) => {
      e.preventDefault();
      wheel += e.deltaMode === 1 ? e.deltaY * 33 : e.deltaY;
      if (Math.abs(wheel) < 50) return;
      const r = canvas.getBoundingClientRect();
      step(wheel < 0 ? 1 : -1, e.clientX - r.left, e.clientY - r.top);
      wheel = 0;
    }, { passive: false });
    let drag = null;
    viewport.addEventListener('pointerdown', (e) => {
      if (e.button !== 0) return;
      drag = { x: e.clientX, y: e.clientY, ox: st.ox, oy: st.oy, moved: false };
      viewport.setPointerCapture(e.pointerId);
    });
    viewport.addEventListener('pointermove', (e) => {
      const r = canvas.getBoundingClientRect();
      st.cursorCss = [e.clientX - r.left, e.clientY - r.top];
      if (drag) {
        const dx = e.clientX - drag.x;
        const dy = e.clientY - drag.y;
        if (drag.moved || Math.abs(dx) + Math.abs(dy) > 3) {
          drag.moved = true;
          viewport.classList.add('dragging');
          st.ox = snap(drag.ox + dx);
          st.oy = snap(drag.oy + dy);
          draw();
        }
      }
      st.cursor = filmAt(e.clientX, e.clientY);
      inspect();
    });
    viewport.addEventListener('pointerup', (e) => {
      if (drag && !drag.moved) {
        const p = filmAt(e.clientX, e.clientY);
        st.pinned = st.pinned || !p ? null : p;
        inspect();
      }
      drag = null;
      viewport.classList.remove('dragging');
    });
    viewport.addEventListener('pointerleave', () => { st.cursorCss = null; });

    // ----- the page -----
    const main = document.getElementById('main');
    main.replaceChildren(
      el('div', { class: 'toolbar' },
        el('div', { class: 'group' }, el('span', { class: 'name' }, 'image'), imageButtons),
        layers.length ? el('div', { class: 'group' }, el('span', { class: 'name' }, 'map'), layerButtons,
          el('span', { class: 'name' }, 'opacity'), opacity) : null,
        el('div', { class: 'group' }, el('span', { class: 'name' }, 'exposure'), slider, stopsText),
        el('div', { class: 'group' }, zoomText, el('button', { onclick: () => fit() }, 'fit', el('kbd', {}, '0')))),
      legend,
      el('div', { class: 'stage' }, viewport,
        el('aside', {}, el('h2', {}, 'Pixel inspector'), inspectorHead,
          el('table', {}, el('thead', {}, el('tr', {}, el('th', {}, 'image'), el('th', {}, 'R'), el('th', {}, 'G'), el('th', {}, 'B'))), inspector),
          el('p', { class: 'dim' }, 'Linear values as stored in the page (half floats: 11 significant bits).'))),
      metrics(record, images, show),
      keyList(keys, 'Click an image button or a row of the table to show that image. Drag to pan, wheel to zoom; zoom steps are powers of two, drawn nearest-neighbour.'),
      section('Provenance', provenance(record.provenance, [
        ['adapter (report)', record.adapter && `${record.adapter} · ${record.backend || ''} · clock: ${record.clock || ''}`],
        ['crate version (report)', record.version],
        ['reference', record.reference && (record.reference.exact || `${record.reference.spp} spp, ${record.reference.path}${record.reference.cached ? ' (cached)' : ''}`)],
        ['page', `${page.generator}, from ${page.record}`],
      ])));

    return Promise.all(loads).then(() => {
      resize();
      fit();
      if (window.ResizeObserver) new ResizeObserver(() => { resize(); draw(); }).observe(viewport);
      hook.state = () => {
        const r = canvas.getBoundingClientRect();
        return {
          kind: page.kind, image: st.image, label: images[st.image].label, file: images[st.image].file,
          mapFile: currentMap() ? images[st.image].mapFiles[st.layer] : null, images: images.map((i) => i.label),
          layer: st.layer, layerShown: !!currentMap(), layers: layers.map((l) => l.key),
          maps: images.map((i) => Object.keys(i.maps)), stops: st.stops, zoom: st.zoom, ox: st.ox, oy: st.oy,
          opacity: st.opacity, film: [W, H], dpr, canvas: { left: r.left, top: r.top, width: r.width, height: r.height },
        };
      };
      hook.filmToClient = (x, y) => {
        const r = canvas.getBoundingClientRect();
        return { x: r.left + st.ox + (x + 0.5) * st.zoom, y: r.top + st.oy + (y + 0.5) * st.zoom };
      };
    });
  }

  function metrics(record, images, show) {
    const m = record.methods || [];
    const ref = record.reference || {};
    const rows = images.map((img) => ({ img, r: img.report }));
    const col = (h, v, f, t) => ({ h, v: (row) => (row.r ? v(row.r) : null), f, text: t });
    const table = sortable([
      { h: 'key', v: (row) => row.img.index, f: (v) => (v === 0 ? 'r' : String(v)) },
      { h: 'image', v: (row) => row.img.label, f: (v) => v, text: true },
      { h: 'spp', v: (row) => (row.r ? row.r.spp : ref.spp) },
      col('samples', (r) => r.samples),
      col('time ms', (r) => r.time_ms && r.time_ms.total),
      { h: 'RelMSE', v: (row) => (row.r ? row.r.relmse : ref.relmse_estimate), f: (v, row) => (row.r ? num(v) : v === undefined || v === null ? '—' : `≈${num(v)} (estimate)`) },
      col('95% interval', (r) => (r.relmse_ci95 ? r.relmse_ci95[0] : null), (v, row) => interval(row.r && row.r.relmse_ci95) || '—'),
      col('seeds', (r) => (r.seeds ? r.seeds.length : null)),
      col('FLIP', (r) => (r.image_flip === undefined ? null : r.image_flip)),
      col('image RelMSE', (r) => r.image_relmse),
      col('relative bias [95%]', (r) => (r.relative_bias ? r.relative_bias[0] : null), (v, row) => (row.r ? biasCell(row.r.relative_bias, row.r.relative_bias_ci95) : '—')),
    ], rows, { pick: (row) => show(row.img.index), decorate: (tr, row) => { tr.dataset.image = row.img.index; } });

    const eq = record.equal_time || {};
    const lines = [];
    const es = eq.equal_samples;
    if (eq.baseline) lines.push(`Baseline of the ratios: ${eq.baseline}.`);
    lines.push(`Equal time (${eq.mode === 'budget' ? 'a time budget' : "MDAS's time"}, target ${num(eq.target_ms)} ms): RelMSE MDAS / Halton = ${withCi(eq.relmse_ratio, eq.relmse_ratio_ci95)}` +
      ` (MDAS ${num(eq.mdas_relmse)}, Halton ${num(eq.halton_relmse)} interpolated at ${num(eq.halton_spp)} spp${eq.halton && eq.halton.bracketed === false ? '; NOT bracketed: the times were not equal' : ''}).`);
    if (es) {
      lines.push(`Equal samples (${es.spp} spp): RelMSE MDAS / Halton = ${withCi(es.relmse_ratio, es.relmse_ratio_ci95)} (MDAS ${withCi(es.mdas_relmse, es.mdas_relmse_ci95)}, Halton ${withCi(es.halton_relmse, es.halton_relmse_ci95)}).`);
      if (es.adaptivity_ratio !== undefined) lines.push(`Adaptivity: RelMSE MDAS / MDAS-uniform = ${withCi(es.adaptivity_ratio, es.adaptivity_ratio_ci95)}.`);
    }
    // Pixel-adaptive Halton, the third method (report.json equal_time.adaptive).
    const third = (what, a) => `${what}: pixel-adaptive Halton at a budget of ${a.spp} spp (spent ${num(a.spp_used)}), RelMSE ${withCi(a.relmse, a.relmse_ci95)}; ` +
      `adaptive / Halton = ${withCi(a.adaptive_over_halton, a.adaptive_over_halton_ci95)}, MDAS / adaptive = ${withCi(a.mdas_over_adaptive, a.mdas_over_adaptive_ci95)}.` +
      (a.notes && a.notes.length ? ` ${a.notes.join(' ')}` : '');
    if (eq.adaptive) {
      const a = eq.adaptive;
      lines.push(third(`Equal time (its run ${num(a.time_ms)} ms${a.search && a.search.bracketed === false ? ', NOT bracketed' : ''})`, a));
    }
    if (es && es.adaptive) lines.push(third(`Equal samples (${es.spp} spp)`, es.adaptive));
    const flags = [].concat(eq.flags || [], (eq.halton_fit && eq.halton_fit.flags) || [], ref.flag || []);
    let samplers = null;
    if (Array.isArray(eq.samplers)) {
      samplers = [el('h2', {}, 'Light samplers under Halton at the target time'), sortable([
        { h: 'sampler', v: (s) => s.sampler, f: (v) => v, text: true },
        { h: 'light samples / evaluation', v: (s) => s.light_samples_per_eval },
        { h: 'RelMSE', v: (s) => s.relmse },
        { h: 'MSE', v: (s) => s.mse },
        { h: 'MSE / uniform', v: (s) => (s.mse_vs_uniform === undefined ? null : s.mse_vs_uniform) },
        { h: 'seeds', v: (s) => (s.seeds ? s.seeds.count : null) },
        { h: 'RelMSE over seeds [95%]', v: (s) => (s.seeds ? s.seeds.relmse : null), f: (v, s) => (s.seeds ? withCi(s.seeds.relmse, s.seeds.relmse_ci95) : '—') },
        { h: 'MSE / uniform over seeds [95%]', v: (s) => (s.seeds && s.seeds.mse_vs_uniform !== undefined ? s.seeds.mse_vs_uniform : null), f: (v, s) => (v === null ? '—' : withCi(v, s.seeds.mse_vs_uniform_ci95)) },
        { h: 'bracketed', v: (s) => String(s.search && s.search.bracketed), f: (v) => v },
      ], eq.samplers, { pick: (s) => { const i = images.findIndex((img) => img.label === s.method); if (i >= 0) show(i); } })];
    }
    return section(`Figures: ${record.scene} · ${record.film.width}×${record.film.height} · scale ${record.scale}${record.sampler ? ` · sampler ${record.sampler}` : ''}`,
      table, el('div', {}, lines.map((l) => el('p', {}, l))), samplers, flagList(flags),
      el('p', { class: 'dim' }, `${m.length} methods; times are medians over ${record.repeats} repeats (${record.clock}); intervals are 95 %.`));
  }

  // ---------- sweep and tune ----------
  function sweep(record, page) {
    const plot = page.plot ? el('img', { class: 'plot', alt: 'RelMSE against time', src: `data:image/svg+xml;base64,${text('mdas-plot')}` }) : el('p', { class: 'dim' }, 'no sweep.svg beside the record');
    const rows = record.rows || [];
    return [
      section(`Sweep: ${record.scene} · scale ${record.scale} · reference ${record.reference_exact || `${record.reference_spp} spp (seed ${record.reference_seed})`}`, plot),
      section('Points', sortable([
        { h: 'method', v: (r) => r.method, f: (v) => v, text: true },
        { h: 'spp', v: (r) => r.spp },
        { h: 'samples', v: (r) => r.samples },
        { h: 'time ms', v: (r) => r.time_ms },
        { h: 'RelMSE', v: (r) => r.relmse },
        { h: '95% low', v: (r) => r.relmse_ci95 && r.relmse_ci95[0] },
        { h: '95% high', v: (r) => r.relmse_ci95 && r.relmse_ci95[1] },
        { h: 'MSE', v: (r) => r.mse },
        { h: 'seeds', v: (r) => (r.seeds ? r.seeds.length : null) },
      ], rows)),
      section('Skipped', el('p', {}, record.mdas_skipped && record.mdas_skipped.length
        ? `MDAS budgets below its initial samples, skipped: ${record.mdas_skipped.join(', ')} spp.` : 'Nothing skipped.')),
      keyList([{ label: 'click', doc: 'a column header sorts the table by it (again: reversed)' }]),
      section('Provenance', provenance(record.provenance, [['repeats', record.repeats], ...partList(record.merged_from), ['page', `${page.generator}, from ${page.record}`]])),
    ];
  }

  function tune(record, page) {
    const rows = record.rows || [];
    const fit = record.halton_fit;
    return [
      section(`Tune: ${record.scene} · scale ${record.scale} · MDAS budget ${record.spp} spp · ranked by ${record.ranking}`,
        el('p', {}, `Grid: ${(record.grid || []).map(([k, v]) => `${k} ∈ {${v.join(', ')}}`).join(' × ') || 'none'}. ` +
          `Seeds: MDAS ${(record.mdas_seeds || []).join(', ')}; Halton ${(record.halton_seeds || []).join(', ')}. ` +
          `Reference: ${record.reference_exact || `${record.reference_spp} spp (seed ${record.reference_seed})`}.`),
        flagList(record.flags || [])),
      section('Configurations (ranked, best first)', sortable([
        { h: 'rank', v: (r) => rows.indexOf(r) + 1 },
        { h: 'configuration', v: (r) => r.label, f: (v) => v, text: true },
        { h: 'RelMSE', v: (r) => r.relmse },
        { h: '95% interval', v: (r) => r.relmse_ci95 && r.relmse_ci95[0], f: (v, r) => interval(r.relmse_ci95) },
        { h: 'relative bias [95%]', v: (r) => r.relative_bias && r.relative_bias[0], f: (v, r) => biasCell(r.relative_bias, r.relative_bias_ci95) },
        { h: 'MSE bias²', v: (r) => r.mse_bias2 },
        { h: 'MSE variance', v: (r) => r.mse_variance },
        { h: 'time ms', v: (r) => r.time_ms },
        { h: 'equal samples ratio', v: (r) => r.equal_samples_ratio },
        { h: 'Halton spp at its time', v: (r) => r.equal_time_halton_spp },
        { h: 'Halton RelMSE there', v: (r) => r.equal_time_halton_relmse },
        { h: 'equal time ratio', v: (r) => r.equal_time_ratio },
      ], rows)),
      section('Halton points', sortable([
        { h: 'spp', v: (p) => p.spp },
        { h: 'RelMSE', v: (p) => p.relmse },
        { h: '95% interval', v: (p) => p.relmse_ci95 && p.relmse_ci95[0], f: (v, p) => interval(p.relmse_ci95) },
        { h: 'relative bias', v: (p) => p.relative_bias && p.relative_bias[0], f: (v, p) => biasCell(p.relative_bias) },
        { h: 'time ms', v: (p) => p.time_ms },
      ], record.halton || []), fit ? el('p', { class: 'dim' }, `Time fit: ${num(fit.a)} + ${num(fit.b)} · spp ms (largest residual ${num(fit.max_residual)}).`) : null,
      fit ? flagList(fit.flags || []) : null),
      section('Skipped configurations', (record.skipped || []).length
        ? sortable([{ h: 'configuration', v: (s) => s[0], f: (v) => v, text: true }, { h: 'reason', v: (s) => s[1], f: (v) => v, text: true }], record.skipped)
        : el('p', {}, 'None.')),
      section('Best [mdas] table', record.best_table ? el('pre', {}, record.best_table) : el('p', {}, 'None (no configuration ran).')),
      keyList([{ label: 'click', doc: 'a column header sorts the table by it (again: reversed)' }]),
      section('Provenance', provenance(record.provenance, [['reference', record.reference_path], ...partList(record.merged_from), ['page', `${page.generator}, from ${page.record}`]])),
    ];
  }

  // ---------- start ----------
  function start() {
    const t0 = performance.now();
    const record = JSON.parse(text('mdas-record'));
    const page = JSON.parse(text('mdas-page'));
    const main = document.getElementById('main');
    let done;
    if (page.kind === 'compare' || page.kind === 'samplers') {
      done = comparison(record, page);
    } else {
      main.replaceChildren(...(page.kind === 'sweep' ? sweep : tune)(record, page));
      hook.state = () => ({ kind: page.kind, rows: (record.rows || []).length });
      done = Promise.resolve();
    }
    return done.then(() => {
      hook.loadMs = performance.now();
      hook.ready = true;
      status(`${page.kind} · ready in ${Math.round(hook.loadMs)} ms (set-up ${Math.round(hook.loadMs - t0)} ms)`);
    });
  }
  function fail(e) {
    hook.error = String((e && e.stack) || e);
    status(`This page could not be shown: ${e}`, true);
    throw e;
  }
  try {
    start().catch(fail);
  } catch (e) {
    fail(e);
  }
})();
