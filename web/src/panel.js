// The parameter panel, generated from the parameter table (`relief explain --json`, served at
// /api/params) and the resolved recipe: one folder per recipe stage, one control per parameter,
// each with its description as help text. Nothing here names a stage or a parameter: stages and
// parameters that land later appear without changes.
import GUI from 'lil-gui';

// A slider step with about 500 positions over the range, rounded to a power of ten.
function niceStep(min, max, isInt) {
  if (isInt) return 1;
  const range = max - min;
  if (!(range > 0)) return 0.001;
  return Math.pow(10, Math.floor(Math.log10(range / 200)));
}

// Sliders only where a linear slider is usable; wide ranges (1..1e7 m) get a number box that
// still drags, clamped to the range.
function sliderUsable(info) {
  const range = info.max - info.min;
  if (info.type === 'int') return range <= 256;
  return info.min < 0 || info.min === 0 ? range <= 1000 : info.max / info.min <= 1000;
}

export function helpText(info, path) {
  const parts = [info.description || ''];
  if (info.type === 'int' || info.type === 'float') parts.push(`${info.type} ${info.min} … ${info.max}${info.unit ? ' ' + info.unit : ''}`);
  else if (info.type === 'choice') parts.push(`one of ${info.choices.join(', ')}`);
  else parts.push(info.type);
  parts.push(info.effect === 'recolour' ? 'recolours only (fast)' : 'regenerates from this stage on');
  return { title: `${path}`, body: parts.filter(Boolean).join(' · ') };
}

export class Panel {
  // callbacks: onChange({path, info, finished}), onHelp({title, body}), onStructure(recipe)
  constructor(container, callbacks) {
    this.container = container;
    this.cb = callbacks;
    this.gui = null;
    this.controllers = new Map();  // path → lil-gui controller
    this.uploads = [];             // the controls of parameters that take a file: {path, stage, take(file)}
    // A file dropped on the panel goes to the file control of the stage it lands on, else to the
    // first one in the panel.
    container.addEventListener('dragover', (e) => {
      if (!e.dataTransfer || ![...e.dataTransfer.types].includes('Files')) return;
      e.preventDefault();
      e.dataTransfer.dropEffect = this.uploads.length ? 'copy' : 'none';
      container.classList.add('dropping');
    });
    container.addEventListener('dragleave', (e) => {
      if (!container.contains(e.relatedTarget)) container.classList.remove('dropping');
    });
    container.addEventListener('drop', (e) => {
      container.classList.remove('dropping');
      const file = e.dataTransfer && e.dataTransfer.files && e.dataTransfer.files[0];
      if (!file) return;
      e.preventDefault();
      this.dropFile(file, e.target);
    });
  }

  // Sends `file` to the upload control of the stage under `target` (an element), else the first one.
  dropFile(file, target) {
    const folder = target && target.closest ? target.closest('[data-stage]') : null;
    const stage = folder ? folder.dataset.stage : null;
    const u = this.uploads.find((x) => x.stage === stage) || this.uploads[0];
    if (!u) {
      if (this.cb.onNoUploadTarget) this.cb.onNoUploadTarget(file);
      return Promise.resolve(false);
    }
    return u.take(file);
  }

  build(recipe, table) {
    if (this.gui) this.gui.destroy();
    this.controllers.clear();
    this.uploads = [];
    this.recipe = recipe;
    this.table = table;
    const gui = new GUI({ container: this.container, title: 'Recipe', width: 330 });
    this.gui = gui;
    gui.domElement.id = 'panel';

    const world = gui.addFolder('World');
    for (const info of table.world) {
      if (info.name === 'size') continue;  // the toolbar's preview size
      this.addControl(world, recipe.world, info, `world.${info.name}`);
    }
    world.close();

    recipe.stages.forEach((stage, i) => {
      const def = table.stages.find((d) => d.name === stage.stage);
      const title = `${i + 1} · ${stage.label || stage.stage}`;
      const folder = gui.addFolder(title);
      folder.domElement.dataset.stage = String(i);
      if (def) {
        folder.$title.title = `${def.name}: ${def.summary}`;
        folder.$title.addEventListener('mouseenter', () => this.cb.onHelp({ title: `${title} (${def.name})`, body: def.summary }));
        for (const info of def.params) {
          if (!(info.name in stage)) continue;
          this.addControl(folder, stage, info, `stages[${i}].${info.name}`);
        }
      }
      folder.add({ remove: () => this.removeStage(i) }, 'remove').name('✕ remove this stage');
      folder.close();
    });

    // Adding stages: every registered stage, inserted at a chosen position.
    const add = gui.addFolder('Add a stage');
    const choice = { stage: table.stages[0] ? table.stages[0].name : '', position: recipe.stages.length + 1 };
    add.add(choice, 'stage', table.stages.map((d) => d.name)).name('stage');
    add.add(choice, 'position', 1, recipe.stages.length + 1, 1).name('position');
    add.add({ add: () => this.insertStage(choice.stage, choice.position - 1) }, 'add').name('＋ insert');
    add.close();

    // Open the first stage so the main sliders are in view.
    const first = gui.folders[1];
    if (first) first.open();
    return gui;
  }

  addControl(folder, obj, info, path) {
    const help = helpText(info, path);
    let c;
    const changed = (finished) => this.cb.onChange({ path, info, finished });
    switch (info.type) {
      case 'int':
      case 'float': {
        if (sliderUsable(info)) {
          c = folder.add(obj, info.name, info.min, info.max, niceStep(info.min, info.max, info.type === 'int'));
        } else {
          c = folder.add(obj, info.name).min(info.min).step(niceStep(info.min, info.max, info.type === 'int'));
          c.onChange((v) => {
            if (v > info.max) {
              obj[info.name] = info.max;
              c.updateDisplay();
            }
          });
        }
        break;
      }
      case 'bool':
        c = folder.add(obj, info.name);
        break;
      case 'choice':
        c = folder.add(obj, info.name, info.choices);
        break;
      case 'color':
        c = folder.addColor(obj, info.name);
        break;
      case 'levels': {
        const sub = folder.addFolder(`${info.name} (${obj[info.name].length})`);
        sub.domElement.title = help.body;
        obj[info.name].forEach((level, k) => {
          const label = level.name || `level ${k + 1}`;
          const at = sub.add(level, 'at', info.min, info.max, 0.001).name(`${label} ≤`);
          this.decorate(at, info, `${path}[${k}].at`, changed);
          const col = sub.addColor(level, 'color').name(`${label} colour`);
          this.decorate(col, info, `${path}[${k}].color`, changed);
        });
        sub.close();
        return;
      }
      case 'curve': {
        const sub = folder.addFolder(`${info.name} (${obj[info.name].length} points)`);
        sub.domElement.title = help.body;
        obj[info.name].forEach((pt, k) => {
          const x = sub.add(pt, 0, info.min, info.max, 0.001).name(`point ${k + 1} x`);
          this.decorate(x, info, `${path}[${k}][0]`, changed);
          const y = sub.add(pt, 1, info.min, info.max, 0.001).name(`point ${k + 1} y`);
          this.decorate(y, info, `${path}[${k}][1]`, changed);
        });
        sub.close();
        return;
      }
      default:  // text: applied when editing ends, not per keystroke
        c = folder.add(obj, info.name);
        this.decorate(c, info, path, null);
        c.onFinishChange(() => changed(true));
        if (info.upload) this.addUpload(folder, obj, info, path, c, changed);
        return;
    }
    this.decorate(c, info, path, changed);
  }

  // A parameter that names a file (the table marks it `upload`): the server reads no file a page
  // names, so the file is uploaded (a file picker, or a file dropped on the panel) and the
  // parameter set to the "upload:NAME" the server gives it.
  addUpload(folder, obj, info, path, text, changed) {
    const input = document.createElement('input');
    input.type = 'file';
    input.hidden = true;
    input.dataset.upload = path;
    const take = async (file) => {
      const name = this.cb.onUpload ? await this.cb.onUpload(file, path) : null;
      if (!name) return false;
      obj[info.name] = name;
      text.updateDisplay();
      changed(true);
      return true;
    };
    input.onchange = () => {
      const file = input.files[0];
      input.value = '';
      if (file) take(file);
    };
    const button = folder.add({ choose: () => input.click() }, 'choose').name(`📂 ${info.name}: choose or drop a file…`);
    button.domElement.appendChild(input);
    button.domElement.dataset.uploadButton = path;
    button.domElement.title = 'Upload an image (PNG 8/16-bit, OpenEXR, GeoTIFF, .r16) for this stage; or drop the file on the panel';
    const folderEl = folder.domElement.closest('[data-stage]');
    this.uploads.push({ path, stage: folderEl ? folderEl.dataset.stage : null, take });
  }

  decorate(c, info, path, changed) {
    const help = helpText(info, path);
    c.domElement.title = `${info.name}: ${help.body}`;
    c.domElement.dataset.param = path;
    c.domElement.addEventListener('mouseenter', () => this.cb.onHelp({ title: `${info.name}${info.unit ? ' [' + info.unit + ']' : ''}`, body: help.body, path }));
    if (changed) {
      c.onChange(() => changed(false));
      c.onFinishChange(() => changed(true));
    }
    this.controllers.set(path, c);
  }

  removeStage(i) {
    this.recipe.stages.splice(i, 1);
    this.cb.onStructure(this.recipe);
  }

  insertStage(name, position) {
    const def = this.table.stages.find((d) => d.name === name);
    if (!def) return;
    const stage = { stage: name };
    for (const p of def.params) stage[p.name] = structuredClone(p.default);
    this.recipe.stages.splice(Math.max(0, Math.min(position, this.recipe.stages.length)), 0, stage);
    this.cb.onStructure(this.recipe);
  }

  updateDisplay() {
    if (this.gui) for (const c of this.gui.controllersRecursive()) c.updateDisplay();
  }
}
