// The 2D tabs: a raster (occupancy grid or height map, nav_msgs layout: cell (i, j) covers
// [origin_x + i*res, ...) x [origin_y + j*res, ...), x fastest) drawn on a canvas with north
// (+y) up, a legend, and the world coordinates of the cell under the mouse.

const RAMP = [[68, 1, 84], [59, 82, 139], [33, 145, 140], [94, 201, 98], [253, 231, 37]];  // viridis

export function ramp(t) {
  t = Math.min(1, Math.max(0, t)) * (RAMP.length - 1);
  const i = Math.min(Math.floor(t), RAMP.length - 2);
  const f = t - i;
  return RAMP[i].map((a, k) => Math.round(a + (RAMP[i + 1][k] - a) * f));
}

function decodeBase64(text) {
  const raw = atob(text || '');
  const out = new Int8Array(raw.length);
  for (let i = 0; i < raw.length; i++) out[i] = raw.charCodeAt(i) << 24 >> 24;
  return out;
}

export class RasterView {
  // `describe(i, j)` -> text for the cell under the mouse.
  constructor(canvas, legend, coords) {
    this.canvas = canvas;
    this.legend = legend;
    this.coords = coords;
    this.raster = null;
    canvas.addEventListener('mousemove', (e) => this.hover(e));
    canvas.addEventListener('mouseleave', () => { this.coords.textContent = ''; });
  }

  // Draws `raster` with colourOf(index) -> [r, g, b] or null (transparent).
  draw(raster, colourOf, describe) {
    this.raster = raster;
    this.describe = describe;
    const { width, height } = raster;
    this.canvas.width = Math.max(width, 1);
    this.canvas.height = Math.max(height, 1);
    const ctx = this.canvas.getContext('2d');
    const image = ctx.createImageData(this.canvas.width, this.canvas.height);
    for (let j = 0; j < height; j++) {
      for (let i = 0; i < width; i++) {
        const colour = colourOf(j * width + i);
        const p = ((height - 1 - j) * width + i) * 4;  // north up
        if (!colour) continue;
        image.data.set(colour, p);
        image.data[p + 3] = 255;
      }
    }
    ctx.putImageData(image, 0, 0);
    this.fit();
  }

  // Integer zoom to fill the space the canvas has.
  fit() {
    if (!this.raster) return;
    const box = this.canvas.parentElement;
    const zoom = Math.max(1, Math.floor(Math.min((box.clientWidth - 140) / this.canvas.width,
                                                 (box.clientHeight - 16) / this.canvas.height)));
    this.canvas.style.width = `${this.canvas.width * zoom}px`;
    this.canvas.style.height = `${this.canvas.height * zoom}px`;
  }

  hover(event) {
    const r = this.raster;
    if (!r) return;
    const scale = this.canvas.clientWidth / this.canvas.width;
    const i = Math.floor(event.offsetX / scale);
    const j = r.height - 1 - Math.floor(event.offsetY / scale);
    if (i < 0 || j < 0 || i >= r.width || j >= r.height) return;
    const x = (r.originX || 0) + (i + 0.5) * r.resolution;
    const y = (r.originY || 0) + (j + 0.5) * r.resolution;
    this.coords.textContent = `x = ${x.toFixed(3)} m, y = ${y.toFixed(3)} m  (cell ${i}, ${j}): ${this.describe(j * r.width + i)}`;
  }
}

export function drawGrid(view, grid) {
  const cells = decodeBase64(grid.data);
  const colours = { '-1': [70, 70, 78], 0: [235, 235, 235], 100: [20, 20, 20] };
  const names = { '-1': 'unknown', 0: 'free', 100: 'occupied' };
  view.draw(grid, (k) => colours[cells[k]] || [200, 60, 60], (k) => names[cells[k]] ?? String(cells[k]));
  view.legend.innerHTML = ['free', 'occupied', 'unknown']
    .map((name, k) => `<div><span class="swatch" style="background:rgb(${colours[[0, 100, -1][k]]})"></span>${name}</div>`)
    .join('') + `<div>${grid.width} x ${grid.height} cells</div><div>${(grid.resolution * 100).toFixed(1)} cm</div>`;
  let known = 0;
  for (const c of cells) if (c !== -1) known++;
  return known;
}

export function drawHeights(view, map) {
  const heights = (map.heights || []).map(Number);
  let lo = Infinity;
  let hi = -Infinity;
  for (const h of heights) if (Number.isFinite(h)) { lo = Math.min(lo, h); hi = Math.max(hi, h); }
  const span = hi > lo ? hi - lo : 1;
  view.draw(map, (k) => (Number.isFinite(heights[k]) ? ramp((heights[k] - lo) / span) : null),
            (k) => (Number.isFinite(heights[k]) ? `z = ${heights[k].toFixed(3)} m` : 'unknown'));
  const stops = [0, 0.25, 0.5, 0.75, 1].map((t) => `rgb(${ramp(1 - t)}) ${t * 100}%`).join(', ');
  view.legend.innerHTML = Number.isFinite(lo)
    ? `<div>${hi.toFixed(2)} m</div><div class="ramp" style="background:linear-gradient(${stops})"></div><div>${lo.toFixed(2)} m</div><div>dark: unknown</div>`
    : '<div>no heights yet</div>';
}
