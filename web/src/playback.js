// Relief Studio: stage playback: the recipe's stages one by one, with a caption per step.
import * as api from './api.js';
import { $, state, view3d, toast, renderTerrain } from './page.js';
import { requestRecipe } from './generator.js';
import { setView } from './views.js';

// ---------------------------------------------------------------------------------- playback
export const playback = { running: false, log: [], delayMs: 1500, stop: false };

export async function playStages() {
  if (playback.running) {
    playback.stop = true;
    return;
  }
  if (!state.recipe) return;
  playback.running = true;
  playback.stop = false;
  playback.log = [];
  $('play').classList.add('active');
  $('play').textContent = '■ Stop';
  try {
    const res = await api.steps(requestRecipe());
    const steps = res.steps;
    const bar = $('steps-bar');
    bar.innerHTML = '';
    steps.forEach((s, k) => {
      const b = document.createElement('button');
      b.textContent = String(k + 1);
      b.title = s.label;
      b.onclick = () => showStep(res, k);
      bar.appendChild(b);
    });
    bar.hidden = false;
    if (state.view !== '3d') setView('3d');
    for (let k = 0; k < steps.length && !playback.stop; k++) {
      showStep(res, k);
      await new Promise((r) => setTimeout(r, playback.delayMs));
    }
  } catch (e) {
    toast(`Stage playback failed: ${e.message}`);
  } finally {
    playback.running = false;
    $('play').classList.remove('active');
    $('play').innerHTML = '&#x25B6; Stages';
    $('caption').hidden = true;
    $('steps-bar').hidden = true;
    if (state.result) renderTerrain(state.result.header.frame, state.result.layers);
  }
}

export function showStep(res, k) {
  const s = res.steps[k];
  const n = res.steps.length;
  const frame = res.header.frame;
  if (s.layers.height) {
    const rgbName = s.layers.color ? 'color' : s.layers.albedo ? 'albedo' : null;
    view3d.setTerrain(frame, s.layers.height.data, rgbName ? s.layers[rgbName].data : null, rgbName !== 'color');
  }
  const cap = $('caption');
  cap.innerHTML = '';
  cap.append(`Step ${k + 1} of ${n} · ${s.label}`);
  const small = document.createElement('small');
  small.textContent = `${s.stage}: ${s.summary} · ${s.cached ? 'cached' : s.ms.toFixed(0) + ' ms'}`;
  cap.appendChild(small);
  cap.hidden = false;
  [...$('steps-bar').children].forEach((b, q) => b.classList.toggle('active', q === k));
  playback.log.push({ index: k, label: s.label, stage: s.stage, caption: cap.textContent });
}

