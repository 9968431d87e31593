// cubeforge view: the controls around the picture. Dragging orbits the camera, the wheel
// moves it in and out; the panel sets the material, its parameters and how the picture is
// shown. Every change is kept in the page's URL query (preview's option names), so a view
// can be shared, reloaded and tested.
'use strict';

window.cubeforgeUi = function (state, mat, scene, redraw) {
  const panel = document.getElementById('panel');
  const canvas = document.getElementById('view');
  const query = new URLSearchParams(location.search);
  function remember(k, v) {
    query.set(k, v);
    history.replaceState(null, '', '?' + query.toString());
  }
  function change(k, v) {
    remember(k, v);
    if (k in state) redraw({ [k]: v });
    else if (k === 'eta') { mat.eta_ratio = [1 / v, 1 / v, 1 / v]; redraw(); }
    else if (k.startsWith('eta_')) { mat.eta_ratio[['eta_red', 'eta_green', 'eta_blue'].indexOf(k)] = 1 / v; redraw(); }
    else { mat[k] = v; redraw(); }
  }
  const h = document.createElement('h1');
  h.textContent = scene.name || 'cubeforge view';
  panel.appendChild(h);
  function select(k, options, value) {
    const l = document.createElement('label');
    l.textContent = k;
    const s = document.createElement('select');
    for (const o of options) {
      const e = document.createElement('option');
      e.value = e.textContent = o;
      s.appendChild(e);
    }
    s.value = value;
    s.onchange = () => {
      if (k === 'layout' || k === 'shading' || k === 'refraction') {
        remember(k, s.value);
        redraw({ [k]: s.value });
      } else if (k === 'material') {
        // Another material: its own parameters, from the page's query.
        const q = new URLSearchParams();
        q.set('material', s.value);
        for (const key of ['size', 'exposure', 'tonemap', 'lod_bias', 'level', 'yaw', 'pitch', 'samples',
                           'layout', 'seams', 'sweep', 'shading', 'tessellation', 'refraction']) {
          if (query.has(key)) q.set(key, query.get(key));
        }
        location.search = '?' + q.toString();
      } else change(k, s.value);
    };
    l.appendChild(s);
    panel.appendChild(l);
  }
  function slider(k, min, max, step, value, target) {
    const l = document.createElement('label');
    const name = document.createElement('span');
    const out = document.createElement('span');
    const r = document.createElement('input');
    Object.assign(r, { type: 'range', min, max, step, value });
    name.textContent = k;
    out.textContent = (+value).toFixed(2);
    r.oninput = () => {
      out.textContent = (+r.value).toFixed(2);
      change(k, parseFloat(r.value));
    };
    l.append(name, r, out);
    panel.appendChild(l);
    return r;
  }
  select('material', Object.keys(scene.materials), state.material);
  select('tonemap', ['none', 'reinhard', 'aces'], state.tonemap);
  if (scene.hdr && !query.has('tonemap')) {
    // Say why the curve is not `none`, preview's default.
    const note = document.createElement('span');
    note.className = 'note';
    note.textContent = 'ACES: the input is HDR';
    panel.lastChild.appendChild(note);
  }
  select('layout', ['sphere', 'cross'], state.layout);
  select('shading', ['per-fragment', 'per-vertex'], state.shading);
  select('refraction', ['texts', 'exact'], state.refraction);
  function check(k, value) {
    const l = document.createElement('label');
    l.textContent = k;
    const c = document.createElement('input');
    c.type = 'checkbox';
    c.checked = value;
    c.onchange = () => {
      remember(k, c.checked ? '1' : '0');
      redraw({ [k]: c.checked });
    };
    l.appendChild(c);
    panel.appendChild(l);
  }
  check('seams', state.seams);
  check('sweep', state.sweep);
  slider('exposure', -8, 8, 0.1, state.exposure);
  const top = scene.env.levels.length - 1;
  slider('level', 0, top, 0.1, state.level);
  slider('lod_bias', 0, Math.max(top, 1), 0.1, state.lod_bias);
  if (mat.model === 'pbr') {
    slider('roughness', 0, 1, 0.01, mat.roughness);
    slider('metallic', 0, 1, 0.01, mat.metallic);
  } else if (mat.model === 'dispersion') {
    ['eta_red', 'eta_green', 'eta_blue'].forEach((k, i) => slider(k, 1, 2.6, 0.005, 1 / mat.eta_ratio[i]));
    slider('reflectivity', 0, 1, 0.01, mat.reflectivity);
    slider('fresnel_bias', 0, 1, 0.01, mat.fresnel_bias);
    slider('fresnel_scale', 0, 2, 0.01, mat.fresnel_scale);
    slider('fresnel_power', 0, 8, 0.1, mat.fresnel_power);
  } else if (mat.model === 'reflect') {
    slider('reflectivity', 0, 1, 0.01, mat.reflectivity);
  } else {
    slider('eta', 1, 2.6, 0.005, 1 / mat.eta_ratio[0]);
    slider('transmittance', 0, 1, 0.01, mat.transmittance);
  }
  slider('tessellation', 2, 64, 1, state.tessellation);
  const yaw = slider('yaw', -180, 180, 1, state.yaw);
  const pitch = slider('pitch', -89, 89, 1, state.pitch);
  if (scene.info) {
    const pre = document.createElement('div');
    pre.id = 'info';
    const i = scene.info;
    const f = (v) => (typeof v === 'number' ? v.toPrecision(4) : v);
    pre.textContent = [
      `${i.face_size || '?'} px faces, ${scene.env.levels.length} level(s), ${i.pixel_format}`,
      i.flux ? `flux (mean radiance) ${i.flux.map(f).join(' ')}` : '',
      `luminance ${f(i.stats.min_luminance)} .. ${f(i.stats.max_luminance)}, mean ${f(i.stats.mean_luminance)}`,
    ].filter(Boolean).join('\n');
    panel.appendChild(pre);
  }
  // Orbit: drag turns the camera about the sphere; the wheel moves it.
  let drag = null;
  canvas.addEventListener('pointerdown', (e) => { drag = [e.clientX, e.clientY, state.yaw, state.pitch]; canvas.setPointerCapture(e.pointerId); });
  canvas.addEventListener('pointerup', () => { drag = null; });
  canvas.addEventListener('pointermove', (e) => {
    if (!drag) return;
    const y = drag[2] - (e.clientX - drag[0]) * 0.4;
    const p = Math.max(-89, Math.min(89, drag[3] + (e.clientY - drag[1]) * 0.4));
    const wrapped = ((y + 540) % 360) - 180;
    yaw.value = wrapped; pitch.value = p;
    remember('yaw', wrapped.toFixed(1));
    remember('pitch', p.toFixed(1));
    redraw({ yaw: wrapped, pitch: p });
  });
  canvas.addEventListener('wheel', (e) => {
    e.preventDefault();
    const d = Math.max(1.2, Math.min(20, state.distance * Math.exp(e.deltaY * 0.001)));
    remember('distance', d.toFixed(2));
    redraw({ distance: d });
  }, { passive: false });
};
