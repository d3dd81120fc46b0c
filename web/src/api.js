// The REST API of skimapd (docs/api.md), as the viewer uses it. Same origin: the viewer is
// served by the skimapd it shows.
import { decode } from './proto.js';

async function getJson(path) {
  const response = await fetch(path, { headers: { Accept: 'application/json' } });
  const body = await response.json().catch(() => ({}));
  if (!response.ok) {
    const error = new Error(body.message || `${response.status} ${response.statusText}`);
    error.status = response.status;
    throw error;
  }
  return body;
}

// GET `path` in the protobuf binary encoding (Accept: application/x-protobuf), decoded as
// message type `type` (proto.js). Errors come as JSON either way.
async function getProto(path, type) {
  const response = await fetch(path, { headers: { Accept: 'application/x-protobuf' } });
  if (!response.ok) {
    const body = await response.json().catch(() => ({}));
    const error = new Error(body.message || `${response.status} ${response.statusText}`);
    error.status = response.status;
    throw error;
  }
  return decode(type, await response.arrayBuffer());
}

export const mapId = (name) => name.replace(/^maps\//, '');

export async function listMaps() {
  const maps = [];
  let token = '';
  do {
    const page = await getJson(`/v1/maps?pageSize=1000${token ? `&pageToken=${encodeURIComponent(token)}` : ''}`);
    maps.push(...(page.maps || []));
    token = page.nextPageToken || '';
  } while (token);
  return maps;
}

export const getMap = (id) => getJson(`/v1/maps/${id}`);

// Voxels at `level` (0 = full resolution), page after page (protobuf binary), calling
// onPage(voxels, resolution) for each, stopping at `cap` voxels.
export async function getVoxels(id, level, cap, onPage) {
  let token = '';
  let count = 0;
  let resolution = 0;
  do {
    const query = `level=${level}&pageSize=100000${token ? `&pageToken=${encodeURIComponent(token)}` : ''}`;
    const page = await getProto(`/v1/maps/${id}/voxels?${query}`, 'skimap.v1.GetVoxelsResponse');
    resolution = page.resolution;
    const voxels = page.voxels || [];
    count += voxels.length;
    onPage(voxels, resolution);
    token = page.nextPageToken || '';
  } while (token && count < cap);
  return { count, resolution, truncated: Boolean(token) };
}

export const getTrajectory = (id, maxPoses) => getJson(`/v1/maps/${id}/trajectory?maxPoses=${maxPoses}`);

export function getOccupancyGrid(id, band) {
  const q = band ? `?bandMinZ=${band.min}&bandMaxZ=${band.max}` : '';
  return getJson(`/v1/maps/${id}/occupancyGrid${q}`);
}

export const getHeightMap = (id) => getJson(`/v1/maps/${id}/heightMap`);

// Instances of a map with recognition; null when the map has none (FAILED_PRECONDITION).
export async function listInstances(id) {
  try {
    return (await getJson(`/v1/maps/${id}/instances?pageSize=1000`)).instances || [];
  } catch (error) {
    if (error.status === 409 || error.status === 400) return null;
    throw error;
  }
}

// The Labels volume of a map with recognition (GET /v1/maps/{map}/labels), page after
// page, stopping at `cap` voxels: {count, resolution, truncated}.
export async function getLabelVoxels(id, cap, onPage) {
  let token = '';
  let count = 0;
  let resolution = 0;
  do {
    const query = `pageSize=100000${token ? `&pageToken=${encodeURIComponent(token)}` : ''}`;
    const page = await getProto(`/v1/maps/${id}/labels?${query}`, 'skimap.v1.GetLabelVoxelsResponse');
    resolution = page.resolution;
    const voxels = page.voxels || [];
    count += voxels.length;
    onPage(voxels);
    token = page.nextPageToken || '';
  } while (token && count < cap);
  return { count, resolution, truncated: Boolean(token) };
}

// The object database's objects (GET /v1/objects), every page.
export async function listObjects() {
  const objects = [];
  let token = '';
  do {
    const page = await getJson(`/v1/objects?pageSize=1000${token ? `&pageToken=${encodeURIComponent(token)}` : ''}`);
    objects.push(...(page.objects || []));
    token = page.nextPageToken || '';
  } while (token);
  return objects;
}

// Live updates: calls onMap(map) for each `event: map`; returns the EventSource.
export function watchMap(id, onMap, onState) {
  const source = new EventSource(`/v1/maps/${id}/events`);
  source.addEventListener('map', (event) => onMap(JSON.parse(event.data)));
  source.addEventListener('gone', () => onState(false));
  source.onopen = () => onState(true);
  source.onerror = () => onState(false);
  return source;
}
