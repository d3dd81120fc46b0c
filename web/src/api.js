// The REST API of skimapd (docs/api.md), as the viewer uses it. Same origin: the viewer is
// served by the skimapd it shows.
import { decode } from './proto.js';

// The bearer token for a skimapd with --auth_tokens_file (docs/operations.md, "Auth"),
// kept in this tab's sessionStorage and sent on every call; '' = none.
const TOKEN_KEY = 'skimapToken';
export const token = {
  get: () => sessionStorage.getItem(TOKEN_KEY) || '',
  set: (value) => (value ? sessionStorage.setItem(TOKEN_KEY, value) : sessionStorage.removeItem(TOKEN_KEY)),
};

// Called when the server answers 401 (no token, or one it does not know).
let authNeeded = () => {};
export function onAuthNeeded(callback) {
  authNeeded = callback;
}

function headers(accept) {
  const h = { Accept: accept };
  if (token.get()) h.Authorization = `Bearer ${token.get()}`;
  return h;
}

// The error of a failed response: its RestError message, with .status.
async function failure(response) {
  const body = await response.json().catch(() => ({}));
  const error = new Error(body.message || `${response.status} ${response.statusText}`);
  error.status = response.status;
  if (response.status === 401) authNeeded(error);
  return error;
}

export async function getJson(path) {
  const response = await fetch(path, { headers: headers('application/json') });
  if (!response.ok) throw await failure(response);
  return response.json();
}

// GET `path` in the protobuf binary encoding (Accept: application/x-protobuf), decoded as
// message type `type` (proto.js). Errors come as JSON either way.
async function getProto(path, type) {
  const response = await fetch(path, { headers: headers('application/x-protobuf') });
  if (!response.ok) throw await failure(response);
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

// Live updates (GET /v1/maps/{map}/events, server-sent events): calls onMap(map) for each
// `event: map` and onState(open) as the stream opens and closes; reconnects after 1, 2, 4 ..
// 10 s. Read with fetch, not EventSource, which cannot send the Authorization header.
// Returns {close()}.
export function watchMap(id, onMap, onState) {
  const controller = new AbortController();
  let closed = false;
  const run = async () => {
    let delay = 1000;
    while (!closed) {
      try {
        const response = await fetch(`/v1/maps/${id}/events`,
                                     { headers: headers('text/event-stream'), signal: controller.signal });
        if (!response.ok) throw await failure(response);
        onState(true);
        delay = 1000;
        const reader = response.body.pipeThrough(new TextDecoderStream()).getReader();
        let buffer = '';
        for (;;) {
          const { value, done } = await reader.read();
          if (done) break;
          buffer += value.replace(/\r\n?/g, '\n');
          let end;
          while ((end = buffer.indexOf('\n\n')) >= 0) {
            const block = buffer.slice(0, end);
            buffer = buffer.slice(end + 2);
            let event = 'message';
            const data = [];
            for (const line of block.split('\n')) {
              if (line.startsWith('event:')) event = line.slice(6).trim();
              else if (line.startsWith('data:')) data.push(line.slice(5).replace(/^ /, ''));
            }
            if (event === 'map' && data.length) onMap(JSON.parse(data.join('\n')));
            if (event === 'gone') onState(false);
          }
        }
      } catch (error) {
        if (closed) return;
      }
      onState(false);
      if (closed) return;
      await new Promise((resolve) => setTimeout(resolve, delay));
      delay = Math.min(2 * delay, 10000);
    }
  };
  run();
  return {
    close() {
      closed = true;
      controller.abort();
    },
  };
}
