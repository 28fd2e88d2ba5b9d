// Relief Studio: saving and loading recipes, and the export menu (the server's writer registry).
import * as api from './api.js';
import { $, state, toast } from './page.js';
import { adopt, requestRecipe, selectPresetOption } from './generator.js';

// ---------------------------------------------------------------------------------- save/load/export
export function download(blob, filename) {
  const url = URL.createObjectURL(blob);
  const a = document.createElement('a');
  a.href = url;
  a.download = filename;
  document.body.appendChild(a);
  a.click();
  a.remove();
  setTimeout(() => URL.revokeObjectURL(url), 60000);
}

// A recipe that names uploaded images is saved as a zip of recipe.json and the images beside it
// (its paths the file names, so `relief generate recipe.json` runs in the unpacked folder).
$('save').onclick = async () => {
  if (!state.recipe) return;
  const r = requestRecipe({ fullSize: true });
  if (!api.namesUpload(r)) {
    download(new Blob([JSON.stringify(r, null, 2) + '\n'], { type: 'application/json' }), `${r.name || 'recipe'}-${r.seed}.json`);
    return;
  }
  try {
    const { blob, filename } = await api.saveZip(r);
    download(blob, filename);
    toast(`Saved ${filename}: recipe.json with its images beside it`, 'info', 3000);
  } catch (e) {
    toast(`Save failed: ${e.message}`);
  }
};
$('load').onclick = () => $('load-file').click();
$('load-file').onchange = async () => {
  const file = $('load-file').files[0];
  $('load-file').value = '';
  if (file) await loadRecipeText(await file.text(), file.name);
};

export async function loadRecipeText(text, name) {
  let doc;
  try {
    doc = JSON.parse(text);
  } catch (e) {
    toast(`Could not load ${name}: not valid JSON (${e.message})`);
    return false;
  }
  try {
    await adopt(doc);
    selectPresetOption(null);
    toast(`Loaded ${name}`, 'info', 2500);
    return true;
  } catch (e) {
    toast(`Could not load ${name}: ${e.message}`);
    return false;
  }
}

export function buildExportMenu() {
  const menu = $('export-menu');
  menu.innerHTML = '';
  const head = document.createElement('div');
  head.className = 'head';
  head.innerHTML = '<span>Export through the same writers as <code>relief generate</code></span>';
  const sizeSel = document.createElement('select');
  sizeSel.id = 'export-size';
  sizeSel.innerHTML = '<option value="preview">at preview size</option><option value="recipe">at recipe size</option>';
  head.appendChild(sizeSel);
  menu.appendChild(head);
  for (const f of state.table.formats) {
    const row = document.createElement('div');
    row.className = 'row';
    const b = document.createElement('button');
    b.className = 'format';
    b.dataset.format = f.name;
    b.textContent = f.files.length > 1 ? `${f.name} (.zip)` : `${f.name} (${f.files[0] || ''})`;
    b.onclick = () => doExport(f.name);
    const desc = document.createElement('div');
    desc.className = 'desc';
    desc.textContent = f.description;
    row.append(b, desc);
    if (f.files.length > 1) {
      const files = document.createElement('div');
      files.className = 'files';
      for (const file of f.files) {
        const a = document.createElement('a');
        a.textContent = file;
        a.dataset.file = file;
        a.onclick = () => doExport(f.name, file);
        files.appendChild(a);
      }
      row.appendChild(files);
    }
    menu.appendChild(row);
  }
}

export async function doExport(format, file) {
  $('export-menu').hidden = true;
  const full = $('export-size') && $('export-size').value === 'recipe';
  toast(`Exporting ${file || format}…`, 'info', 0);
  try {
    const { blob, filename } = await api.exportFormat(requestRecipe({ fullSize: full }), format, file);
    download(blob, filename);
    toast(`Exported ${filename} (${(blob.size / 1024).toFixed(0)} KiB)`, 'info', 3000);
  } catch (e) {
    toast(`Export failed: ${e.message}`);
  }
}
$('export').onclick = (e) => {
  e.stopPropagation();
  $('export-menu').hidden = !$('export-menu').hidden;
};
document.addEventListener('click', (e) => {
  if (!$('export-menu').hidden && !$('export-menu').contains(e.target)) $('export-menu').hidden = true;
});

