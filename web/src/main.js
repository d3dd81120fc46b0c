// SkiMap viewer: the map list, the 3D tab (view3d.js), the occupancy grid and height map
// tabs (raster.js), kept live by the map's server-sent events (GET /v1/maps/{map}/events).
// State in the URL hash: #map=<id>&tab=<view3d|grid|height>. docs/viewer.md.
import './style.css';
import * as api from './api.js';
import { count, bytes } from './format.js';
import { View3D, DEFAULT_BUDGET, INTERACTIVE_MS, objectColour } from './view3d.js';
import { RasterView, drawGrid, drawHeights } from './raster.js';

const $ = (id) => document.getElementById(id);
const params = new URLSearchParams(location.search);
const state = {
  maps: new Map(),  // id -> v1.Map
  selected: null,
  tab: 'view3d',
  events: null,
  stale: { view3d: true, grid: true, height: true },
  band: null,
};

const view3d = new View3D($('canvas3d'), Number(params.get('budget')) || DEFAULT_BUDGET,
                          Number(params.get('interactiveMs')) || INTERACTIVE_MS);
const gridView = new RasterView($('grid-canvas'), $('grid-legend'), $('coords'));
const heightView = new RasterView($('height-canvas'), $('height-legend'), $('coords'));
window.skimapViewer = { state, view3d, drawnPixels: () => view3d.drawnPixels() };

function setStatus(text) {
  $('status').textContent = text || '';
}

function readHash() {
  const h = new URLSearchParams(location.hash.slice(1));
  return { map: h.get('map'), tab: h.get('tab') };
}

function writeHash() {
  const h = new URLSearchParams();
  if (state.selected) h.set('map', state.selected);
  h.set('tab', state.tab);
  history.replaceState(null, '', `#${h}`);
}

function renderList() {
  const body = $('maps').querySelector('tbody');
  body.replaceChildren();
  for (const [id, map] of [...state.maps].sort()) {
    const row = document.createElement('tr');
    row.dataset.map = id;
    row.dataset.voxels = map.stats?.voxels || '0';
    row.dataset.frames = map.stats?.frames || '0';
    if (id === state.selected) row.className = 'selected';
    const cells = [id, count(map.stats?.voxels), count(map.stats?.frames), bytes(map.stats?.memoryBytes)];
    for (const text of cells) {
      const td = document.createElement('td');
      td.textContent = text;
      row.appendChild(td);
    }
    row.addEventListener('click', () => select(id));
    body.appendChild(row);
  }
  if (!state.maps.size) body.innerHTML = '<tr><td colspan="4">no maps yet: stream some frames (README)</td></tr>';
}

function renderDetails() {
  const map = state.maps.get(state.selected);
  if (!map) {
    $('details').textContent = '';
    return;
  }
  const s = map.stats || {};
  const o = map.options || {};
  const b = s.bounds;
  $('details').textContent = [
    `${map.name}`,
    `resolution ${(o.resolution * 100).toFixed(1)} cm`,
    `voxels ${count(s.voxels)}, frames ${count(s.frames)}`,
    `memory ${bytes(s.memoryBytes)}${s.persistent ? ', persistent' : ', in memory only'}`,
    b ? `bounds x ${b.min.x.toFixed(2)}..${b.max.x.toFixed(2)}, y ${b.min.y.toFixed(2)}..${b.max.y.toFixed(2)}, z ${b.min.z.toFixed(2)}..${b.max.z.toFixed(2)} m` : 'empty',
    o.recognition?.enabled ? 'recognition on' : 'recognition off',
  ].join('\n');
}

async function refreshList() {
  try {
    const maps = await api.listMaps();
    state.maps = new Map(maps.map((m) => [api.mapId(m.name), m]));
    renderList();
    renderDetails();
    setStatus('');
  } catch (error) {
    setStatus(`maps: ${error.message}`);
  }
}

// --- views -------------------------------------------------------------------------

const extents = new Map();  // "objects/{id}" -> promise of {min, max} in the model frame
function objectExtent(object) {
  if (!extents.has(object)) {
    extents.set(object, api.getJson(`/v1/${object}?view=OBJECT_VIEW_FULL`).then((o) => {
      const v = o.rgbVoxels || [];
      if (!v.length) return null;
      const min = [Infinity, Infinity, Infinity];
      const max = [-Infinity, -Infinity, -Infinity];
      for (const { center: c } of v) {
        ['x', 'y', 'z'].forEach((k, i) => { min[i] = Math.min(min[i], c[k] || 0); max[i] = Math.max(max[i], c[k] || 0); });
      }
      return { min, max };
    }).catch(() => null));
  }
  return extents.get(object);
}

// Object names by obj_id (GET /v1/objects), read again when an unknown id shows up.
let objectNames = new Map();
async function objectName(objId) {
  if (!objectNames.has(objId)) {
    objectNames = new Map((await api.listObjects()).map((o) => [o.objId, o.displayName || o.name]));
  }
  return objectNames.get(objId) || (objId ? `object ${objId}` : 'unknown class');
}

// The Labels volume of `map` in the 3D view, and its legend (one line per object: colour,
// name, voxels).
async function loadLabels(map) {
  const labels = await view3d.loadLabels(map);
  if (!labels) return;
  const legend = $('labels-legend');
  legend.replaceChildren();
  const entries = Object.entries(labels.byObject).map(([obj, n]) => [Number(obj), n]).sort((a, b) => a[0] - b[0]);
  for (const [obj, n] of entries) {
    const item = document.createElement('li');
    item.dataset.objId = String(obj);
    item.dataset.voxels = String(n);
    item.dataset.colour = objectColour(obj);
    const swatch = document.createElement('span');
    swatch.className = 'swatch';
    swatch.style.background = objectColour(obj);
    item.append(swatch, `${await objectName(obj)}: ${count(n)} label voxels`);
    legend.appendChild(item);
  }
  const title = document.createElement('li');
  title.textContent = `labels volume, ${(labels.resolution * 1000).toFixed(0)} mm voxels${labels.truncated ? ' (truncated)' : ''}`;
  legend.prepend(title);
  document.body.dataset.labelsShown = String(labels.shown);
}

const loaders = {
  async view3d(map) {
    document.body.dataset.trajectory = String(await view3d.loadTrajectory(map));
    const lod = await view3d.load(map, (l) => {
      $('lod').textContent = `${count(l.shown)} of ${count(l.total)} voxels shown, level ${l.level}` +
        ` (${(l.resolution * 100).toFixed(1)} cm boxes${l.partial ? ', loading' : l.truncated ? ', truncated' : ''})` +
        (l.proxyShown ? `; ${count(l.proxyShown)} boxes of ${(l.proxyResolution * 100).toFixed(1)} cm while moving` : '');
    });
    if (lod) {
      document.body.dataset.voxelsShown = String(lod.shown);
      document.body.dataset.proxyShown = String(lod.proxyShown);
    }
    const recognition = Boolean(map.options?.recognition?.enabled);
    $('labels-toggle').hidden = !recognition;
    $('fit-instances').hidden = !recognition;
    if (recognition) {
      const instances = await view3d.loadInstances(map, objectExtent, $('instances'));
      document.body.dataset.instances = instances ? String(instances.length) : 'none';
      if ($('show-labels').checked) await loadLabels(map);
    } else {
      $('instances').replaceChildren();
      view3d.instances.clear();
      document.body.dataset.instances = 'none';
      $('show-labels').checked = false;
      showLabels(false);
    }
  },
  async grid(map) {
    const id = api.mapId(map.name);
    if (!state.band) {
      const o = map.options || {};
      state.band = { min: o.bandMinZ ?? 0.05, max: o.bandMaxZ ?? 1.5 };
      $('band-min').value = state.band.min;
      $('band-max').value = state.band.max;
      showBand();
    }
    const grid = await api.getOccupancyGrid(id, state.band);
    document.body.dataset.gridKnown = String(drawGrid(gridView, grid));
  },
  async height(map) {
    drawHeights(heightView, await api.getHeightMap(api.mapId(map.name)));
    document.body.dataset.heightDrawn = '1';
  },
};

let refreshing = null;
let again = false;
// Reloads the active tab if stale; one load at a time, the next one coalesced.
async function refreshView() {
  if (refreshing) {
    again = true;
    return refreshing;
  }
  const map = state.maps.get(state.selected);
  if (!map || !state.stale[state.tab]) return null;
  const tab = state.tab;
  state.stale[tab] = false;
  refreshing = loaders[tab](map).catch((error) => {
    setStatus(`${tab}: ${error.message}`);
    state.stale[tab] = true;
  }).finally(() => {
    refreshing = null;
    document.body.dataset[`loaded_${tab}`] = String(Date.now());
    if (again) {
      again = false;
      setTimeout(refreshView, 300);
    }
  });
  return refreshing;
}

function showTab(tab) {
  state.tab = tab;
  for (const b of document.querySelectorAll('#tabs button')) b.classList.toggle('active', b.dataset.tab === tab);
  for (const t of document.querySelectorAll('.tab')) t.classList.toggle('active', t.id === tab);
  writeHash();
  if (tab === 'view3d') view3d.resize();
  refreshView();
  gridView.fit();
  heightView.fit();
}

function showBand() {
  $('band-min-v').textContent = Number($('band-min').value).toFixed(2);
  $('band-max-v').textContent = Number($('band-max').value).toFixed(2);
}

// --- live --------------------------------------------------------------------------

function onMapEvent(map) {
  const id = api.mapId(map.name);
  const old = state.maps.get(id);
  state.maps.set(id, map);
  renderList();
  renderDetails();
  document.body.dataset.liveEvents = String(Number(document.body.dataset.liveEvents || 0) + 1);
  if (old && old.stats?.frames === map.stats?.frames && old.stats?.voxels === map.stats?.voxels) return;
  state.stale = { view3d: true, grid: true, height: true };
  refreshView();
}

function select(id) {
  if (state.selected === id && state.events) return;
  state.selected = id;
  state.stale = { view3d: true, grid: true, height: true };
  state.band = null;
  view3d.framed = null;
  view3d.trajectoryBox = null;
  if (state.events) state.events.close();
  state.events = api.watchMap(id, onMapEvent, (on) => {
    $('live').textContent = on ? 'live' : 'offline';
    $('live').className = `live ${on ? 'on' : 'off'}`;
  });
  renderList();
  renderDetails();
  writeHash();
  refreshView();
}

// --- start -------------------------------------------------------------------------

for (const b of document.querySelectorAll('#tabs button')) b.addEventListener('click', () => showTab(b.dataset.tab));
for (const id of ['band-min', 'band-max']) {
  $(id).addEventListener('input', showBand);
  $(id).addEventListener('change', () => {
    let min = Number($('band-min').value);
    let max = Number($('band-max').value);
    if (min > max) [min, max] = [max, min];
    state.band = { min, max };
    state.stale.grid = true;
    refreshView();
  });
}
$('show-trajectory').addEventListener('change', () => {
  view3d.trajectory.visible = $('show-trajectory').checked;
  view3d.requestRender();
});
$('show-instances').addEventListener('change', () => {
  view3d.instances.visible = $('show-instances').checked;
  view3d.requestRender();
});
$('fit-instances').addEventListener('click', () => view3d.frameInstances());
function showLabels(on) {
  view3d.showLabels(on);
  $('labels-legend').hidden = !on;
  if (!on) delete document.body.dataset.labelsShown;
}
$('show-labels').addEventListener('change', async () => {
  const on = $('show-labels').checked;
  showLabels(on);
  const map = state.maps.get(state.selected);
  if (on && map) {
    try {
      await loadLabels(map);
    } catch (error) {
      setStatus(`labels: ${error.message}`);
    }
  }
});
window.addEventListener('resize', () => { gridView.fit(); heightView.fit(); });

// Auth: a 401 shows the token form (the status line says the server's reason); a token given there is kept for this tab
// (api.token) and the page starts again with it.
api.onAuthNeeded(() => {
  $('token-form').hidden = false;
  $('sign-out').hidden = true;
  document.body.dataset.authNeeded = '1';
});
$('sign-out').hidden = !api.token.get();
$('sign-out').addEventListener('click', () => {
  api.token.set('');
  location.reload();
});
$('token-form').addEventListener('submit', (event) => {
  event.preventDefault();
  api.token.set($('token').value.trim());
  location.reload();
});

(async () => {
  await refreshList();
  const wanted = readHash();
  if (wanted.tab && loaders[wanted.tab]) showTab(wanted.tab);
  const first = state.maps.has(wanted.map) ? wanted.map : [...state.maps.keys()].sort()[0];
  if (first) select(first);
  document.body.dataset.ready = '1';
  setInterval(refreshList, 10000);
})();
