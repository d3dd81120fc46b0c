// The 3D tab: the map's RGB volume as instanced boxes (one THREE.InstancedMesh, one box per
// voxel, coloured by the voxel), an orbit camera, the instances found by recognition as
// oriented boxes with their names and scores, and on demand the Labels volume: one box per
// label voxel coloured by the object of its heaviest label (the RGB voxels then turn grey).
// World frame: z up, metres.
//
// Level of detail (docs/viewer.md): the viewer draws at most `budget` voxels. It asks the
// server for the smallest level L (GetVoxels ?level=L: one voxel per block of 2^L voxels a
// side) with stats.voxels / 4^L <= budget (a surface keeps about a quarter of its voxels
// per level), and stops paging at 2 x budget whatever the level gave. Pages come in the
// protobuf binary encoding; a map's first load draws each page as it arrives (a reload
// swaps the mesh when complete, so a live map does not flicker).
//
// Interaction: once loaded, one frame of the voxels is timed; if it takes longer than
// INTERACTIVE_MS (?interactiveMs=), a coarser proxy is drawn instead while the camera
// moves, and the full level again once it settles: blocks of m x m x m voxels merged here,
// m the smallest power of two that brings the frame under that time, keeping about
// MIN_PROXY_BOXES at least.
import * as THREE from 'three';
import { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';
import { getLabelVoxels, getTrajectory, getVoxels, listInstances } from './api.js';

export const DEFAULT_BUDGET = 200000;
// The frame time the view aims at while the camera moves.
export const INTERACTIVE_MS = 40;
// The proxy keeps at least about this many boxes (coarser would no longer show the map).
const MIN_PROXY_BOXES = 1000;
const BACKGROUND = 0x15171a;
// Label voxels: a colour per object id (the palette repeats after 10 objects); white for a
// class the map's classifier does not know (obj_id 0).
const OBJECT_PALETTE = ['#e6194b', '#3cb44b', '#4363d8', '#f58231', '#911eb4', '#42d4f4', '#f032e6',
  '#bfef45', '#fabed4', '#ffe119'];
export const objectColour = (objId) => (objId > 0 ? OBJECT_PALETTE[(objId - 1) % OBJECT_PALETTE.length] : '#ffffff');
// Label voxels are drawn this many times their edge: they are sparse (one per verified
// feature, 5 mm by default) and would be specks otherwise.
const LABEL_BOX_SCALE = 2;

export function chooseLevel(voxels, budget) {
  let level = 0;
  while (level < 8 && voxels / 4 ** level > budget) level++;
  return level;
}

export class View3D {
  constructor(container, budget = DEFAULT_BUDGET, interactiveMs = INTERACTIVE_MS) {
    this.container = container;
    this.budget = budget;
    this.interactiveMs = interactiveMs;
    this.renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
    this.renderer.setPixelRatio(window.devicePixelRatio);
    this.renderer.setClearColor(BACKGROUND);
    container.appendChild(this.renderer.domElement);
    this.scene = new THREE.Scene();
    this.scene.add(new THREE.AmbientLight(0xffffff, 0.75));
    const sun = new THREE.DirectionalLight(0xffffff, 0.9);
    sun.position.set(1, -2, 3);
    this.scene.add(sun);
    this.camera = new THREE.PerspectiveCamera(55, 1, 0.01, 500);
    this.camera.up.set(0, 0, 1);
    this.camera.position.set(2, -2, 2);
    this.controls = new OrbitControls(this.camera, this.renderer.domElement);
    this.controls.enableDamping = true;
    this.controls.addEventListener('change', () => this.requestRender());
    this.interacting = false;  // a pointer drags the camera
    this.controls.addEventListener('start', () => { this.interacting = true; });
    this.controls.addEventListener('end', () => { this.interacting = false; this.requestRender(); });
    this.proxy = null;  // the coarse voxels drawn while the camera moves (or null)
    this.axes = new THREE.AxesHelper(0.3);
    this.scene.add(this.axes);
    this.voxels = null;
    this.instances = new THREE.Group();
    this.scene.add(this.instances);
    this.trajectory = new THREE.Group();
    this.scene.add(this.trajectory);
    this.labels = new THREE.Group();
    this.labels.visible = false;
    this.scene.add(this.labels);
    this.labelObjects = {};  // obj_id -> label voxels shown
    this.voxelColours = null;  // the RGB voxels' colours (0xRRGGBB), for greying them
    this.framed = null;  // the map whose bounds the camera was fitted to
    this.loading = null;
    new ResizeObserver(() => this.resize()).observe(container);
    this.resize();
  }

  resize() {
    const { clientWidth: w, clientHeight: h } = this.container;
    if (!w || !h) return;
    this.renderer.setSize(w, h);
    this.camera.aspect = w / h;
    this.camera.updateProjectionMatrix();
    this.requestRender();
  }

  requestRender() {
    if (this.pending) return;
    this.pending = requestAnimationFrame(() => {
      this.pending = 0;
      const moving = this.controls.update();
      if (moving) this.requestRender();
      this.renderFrame(moving || this.interacting);
    });
  }

  // Draws one frame: with the coarse proxy instead of the voxels when `moving` and a proxy
  // exists.
  renderFrame(moving) {
    const proxy = Boolean(moving && this.proxy);
    if (this.voxels) this.voxels.visible = !proxy;
    if (this.proxy) this.proxy.visible = proxy;
    this.renderer.render(this.scene, this.camera);
    // For the benchmark (bench/viewer_bench.mjs): when the voxels were first drawn.
    if (this.voxels && this.voxels.count > 0 && this.firstVoxelRender === undefined) {
      this.firstVoxelRender = performance.now();
    }
  }

  // Milliseconds to draw and finish one frame with the full voxels (a 1-pixel readPixels
  // waits for the GPU, or for SwiftShader's CPU rasteriser).
  timeFrame() {
    const gl = this.renderer.getContext();
    const pixel = new Uint8Array(4);
    const start = performance.now();
    this.renderFrame(false);
    gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, pixel);
    return performance.now() - start;
  }

  // Fits the camera to the map's bounds once per map.
  frame(map) {
    const b = map.stats && map.stats.bounds;
    if (!b || this.framed === map.name) return;
    this.framed = map.name;
    const box = new THREE.Box3(new THREE.Vector3(b.min.x, b.min.y, b.min.z),
                               new THREE.Vector3(b.max.x, b.max.y, b.max.z));
    if (this.trajectoryBox) box.union(this.trajectoryBox);  // the cameras in view too
    this.fitBox(box, 0.5);
  }

  // Looks at `box` (a THREE.Box3) from above and to the side, close enough to fill the view
  // with it (at least `minSize` metres across).
  fitBox(box, minSize) {
    const { min, max } = box;
    const centre = min.clone().add(max).multiplyScalar(0.5);
    const size = Math.max(max.distanceTo(min), minSize);
    this.controls.target.copy(centre);
    this.camera.position.copy(centre).add(new THREE.Vector3(0.35, -0.55, 0.45).multiplyScalar(size));
    this.camera.near = size / 1000;
    this.camera.far = size * 20;
    this.camera.updateProjectionMatrix();
    this.controls.update();
    this.requestRender();
  }

  // Fits the camera to the instances' boxes; false when there are none.
  frameInstances() {
    const box = new THREE.Box3().setFromObject(this.instances);
    if (box.isEmpty()) return false;
    this.fitBox(box, 0.3);
    return true;
  }

  // (Re)loads the voxels of `map` (a v1.Map); reports the level of detail with onLod
  // (also after the first page of a first load, with `partial` set).
  async load(map, onLod) {
    const id = map.name.replace(/^maps\//, '');
    const voxels = Number(map.stats.voxels || 0);
    const level = chooseLevel(voxels, this.budget);
    const token = {};
    this.loading = token;
    const cap = 2 * this.budget;
    // Progressive on a map's first load: draw each page as it comes.
    const progressive = !this.voxels || this.framed !== map.name;
    const cloud = new VoxelCloud(cap);
    const fetchStart = performance.now();
    let firstPage = null;
    const result = await getVoxels(id, level, cap, (page, resolution) => {
      if (this.loading !== token) return;
      cloud.add(page, resolution);
      if (progressive && firstPage === null) {
        firstPage = performance.now() - fetchStart;
        this.showCloud(cloud);
        this.frame(map);
        if (onLod) onLod({ level, shown: cloud.count, total: voxels, truncated: true, partial: true, resolution });
      } else if (progressive) {
        cloud.sync(this.voxels);
        this.requestRender();
      }
    });
    if (this.loading !== token) return null;  // a newer load started
    const buildStart = performance.now();
    if (progressive) cloud.sync(this.voxels);
    else this.showCloud(cloud);
    this.frame(map);
    const frameMs = this.timeFrame();
    this.buildProxy(cloud, frameMs);
    const lod = { level, shown: cloud.count, total: voxels, truncated: result.truncated,
                  resolution: result.resolution, firstPageMs: firstPage ?? buildStart - fetchStart,
                  fetchMs: buildStart - fetchStart, buildMs: performance.now() - buildStart - frameMs,
                  frameMs, proxyShown: this.proxy ? this.proxy.count : 0,
                  proxyResolution: this.proxyResolution || 0, loadedAt: buildStart };
    this.lastLod = lod;
    if (onLod) onLod(lod);
    this.requestRender();
    return lod;
  }

  // Shows `cloud` (a VoxelCloud) as the voxels, replacing the previous ones and their proxy.
  showCloud(cloud) {
    if (this.voxels) {
      this.scene.remove(this.voxels);
      disposeMesh(this.voxels);
    }
    this.dropProxy();
    this.voxels = cloud.mesh();
    this.voxelColours = cloud.colours;
    this.greyVoxels(this.labels.visible);
    this.scene.add(this.voxels);
    this.requestRender();
  }

  dropProxy() {
    if (!this.proxy) return;
    this.scene.remove(this.proxy);
    disposeMesh(this.proxy);
    this.proxy = null;
    this.proxyResolution = 0;
  }

  // A coarse copy of `cloud` for the moving camera when a full frame took `frameMs` >
  // INTERACTIVE_MS: blocks of m voxels a side (m = 2, 4, ...: a surface keeps about 1/m^2
  // of its voxels) with the mean colour, m the smallest that fits the frame time.
  buildProxy(cloud, frameMs) {
    this.dropProxy();
    if (frameMs <= this.interactiveMs || cloud.count === 0) return;
    let m = 2;
    while (m < 256 && frameMs / (m * m) > this.interactiveMs && cloud.count / (4 * m * m) >= MIN_PROXY_BOXES) m *= 2;
    const coarse = cloud.coarsen(m);
    this.proxy = coarse.mesh();
    this.proxy.visible = false;
    this.proxyResolution = coarse.resolution;
    if (this.labels.visible) greyMesh(this.proxy, coarse.colours, true);
    this.scene.add(this.proxy);
  }

  // Colours the RGB voxels (and their proxy) by their colour, or (grey = true) by its
  // dimmed luminance, see-through: the labels lie on surfaces inside them.
  greyVoxels(grey) {
    if (this.voxels && this.voxelColours) greyMesh(this.voxels, this.voxelColours, grey);
    if (this.proxy) greyMesh(this.proxy, this.proxy.userData.colours, grey);
  }

  // (Re)loads the Labels volume of `map` (GET /v1/maps/{map}/labels, at most 2 x budget
  // voxels), one box per voxel in its object's colour. Returns {shown, byObject (obj_id ->
  // voxels), resolution, truncated}, or null if a newer load started meanwhile.
  async loadLabels(map) {
    const id = map.name.replace(/^maps\//, '');
    const token = {};
    this.labelsLoading = token;
    const positions = [];
    const colours = [];
    const byObject = {};
    const result = await getLabelVoxels(id, 2 * this.budget, (page) => {
      for (const v of page) {
        positions.push(v.center?.x || 0, v.center?.y || 0, v.center?.z || 0);
        const obj = v.objId || 0;
        byObject[obj] = (byObject[obj] || 0) + 1;
        colours.push(parseInt(objectColour(obj).slice(1), 16));
      }
    });
    if (this.labelsLoading !== token) return null;
    for (const child of [...this.labels.children]) {
      this.labels.remove(child);
      disposeMesh(child);
    }
    if (colours.length) this.labels.add(instancedBoxes(positions, colours, LABEL_BOX_SCALE * result.resolution));
    this.labelObjects = byObject;
    this.requestRender();
    return { shown: colours.length, byObject, resolution: result.resolution, truncated: result.truncated };
  }

  // Shows or hides the label voxels (the RGB voxels turn grey while they show).
  showLabels(on) {
    this.labels.visible = on;
    this.greyVoxels(on);
    this.requestRender();
  }

  // The colour of each object among the label voxels shown: {obj_id: "#rrggbb"}.
  labelColours() {
    return Object.fromEntries(Object.keys(this.labelObjects).map((obj) => [obj, objectColour(Number(obj))]));
  }

  // Instances as oriented boxes (the object's extent from its model voxels when known,
  // else 10 cm) with a "name score" label. Returns the instances, or null without
  // recognition.
  async loadInstances(map, extentOf, list) {
    const id = map.name.replace(/^maps\//, '');
    const instances = await listInstances(id);
    this.instances.clear();
    list.replaceChildren();
    if (!instances) return null;
    for (const inst of instances) {
      const extent = (await extentOf(inst.object)) || { min: [-0.05, -0.05, -0.05], max: [0.05, 0.05, 0.05] };
      const size = extent.max.map((v, i) => v - extent.min[i]);
      const box = new THREE.LineSegments(
        new THREE.EdgesGeometry(new THREE.BoxGeometry(...size)),
        // Drawn over the voxels: an object inside the map's surface is still seen.
        new THREE.LineBasicMaterial({ color: 0xffcc33, depthTest: false, transparent: true }));
      box.renderOrder = 2;
      box.position.set(...extent.max.map((v, i) => (v + extent.min[i]) / 2));
      const holder = new THREE.Group();
      const p = inst.pose || {};
      const t = p.translation || {};
      const r = p.rotation || { w: 1 };
      holder.position.set(t.x || 0, t.y || 0, t.z || 0);
      holder.quaternion.set(r.x || 0, r.y || 0, r.z || 0, r.w ?? 1);
      holder.add(box);
      holder.add(label(`${inst.objectName || inst.object} ${Number(inst.score).toFixed(0)}`));
      this.instances.add(holder);
      const item = document.createElement('li');
      item.dataset.object = inst.object;
      item.dataset.score = String(inst.score);
      item.textContent = `${inst.objectName || inst.object}: score ${Number(inst.score).toFixed(0)}, fit ${Number(inst.fit || 0).toFixed(2)}`;
      list.appendChild(item);
    }
    this.requestRender();
    return instances;
  }

  // The camera trajectory (GET /v1/maps/{map}/trajectory): a line through the camera
  // positions, a dot per frame, the last camera's axes. Returns the number of poses.
  async loadTrajectory(map) {
    const id = map.name.replace(/^maps\//, '');
    const trajectory = await getTrajectory(id, 5000);
    for (const child of [...this.trajectory.children]) {
      child.geometry?.dispose();
      this.trajectory.remove(child);
    }
    const poses = trajectory.poses || [];
    if (!poses.length) return 0;
    const points = poses.map(({ pose }) => new THREE.Vector3(
      pose.translation?.x || 0, pose.translation?.y || 0, pose.translation?.z || 0));
    const geometry = new THREE.BufferGeometry().setFromPoints(points);
    this.trajectory.add(new THREE.Line(geometry, new THREE.LineBasicMaterial({ color: 0x33ddff })));
    this.trajectory.add(new THREE.Points(geometry.clone(), new THREE.PointsMaterial({ color: 0x33ddff, size: 5, sizeAttenuation: false })));
    this.trajectoryBox = new THREE.Box3().setFromPoints(points);
    // The last camera as a small frustum (camera frame: x right, y down, z forward).
    const last = poses[poses.length - 1].pose;
    const [w, h, d] = [0.04, 0.03, 0.06];
    const corners = [[-w, -h, d], [w, -h, d], [w, h, d], [-w, h, d]];
    const segments = [];
    corners.forEach((c, i) => segments.push(0, 0, 0, ...c, ...c, ...corners[(i + 1) % 4]));
    const frustum = new THREE.LineSegments(
      new THREE.BufferGeometry().setAttribute('position', new THREE.Float32BufferAttribute(segments, 3)),
      new THREE.LineBasicMaterial({ color: 0x33ddff }));
    frustum.position.copy(points[points.length - 1]);
    const r = last.rotation || {};
    frustum.quaternion.set(r.x || 0, r.y || 0, r.z || 0, r.w ?? 1);
    this.trajectory.add(frustum);
    this.requestRender();
    return poses.length;
  }

  // Pixels of the view that differ from the empty scene's (for tests and the status).
  drawnPixels() {
    const read = () => {
      this.renderer.render(this.scene, this.camera);
      const gl = this.renderer.getContext();
      const pixels = new Uint8Array(gl.drawingBufferWidth * gl.drawingBufferHeight * 4);
      gl.readPixels(0, 0, gl.drawingBufferWidth, gl.drawingBufferHeight, gl.RGBA, gl.UNSIGNED_BYTE, pixels);
      return pixels;
    };
    const shown = this.scene.children.map((c) => c.visible);
    this.scene.children.forEach((c) => { c.visible = c.isLight === true; });
    const empty = read();
    this.scene.children.forEach((c, i) => { c.visible = shown[i]; });
    const full = read();
    let drawn = 0;
    for (let i = 0; i < full.length; i += 4) {
      if (Math.abs(full[i] - empty[i]) + Math.abs(full[i + 1] - empty[i + 1]) + Math.abs(full[i + 2] - empty[i + 2]) > 12) drawn++;
    }
    return { drawn, total: full.length / 4 };
  }
}

// Voxel centres and colours gathered page by page into typed arrays of a fixed capacity,
// drawn as one THREE.InstancedMesh of boxes (one per voxel).
class VoxelCloud {
  constructor(capacity) {
    this.capacity = Math.max(capacity, 1);
    this.positions = new Float32Array(3 * this.capacity);
    this.colours = new Uint32Array(this.capacity);  // 0xRRGGBB, sRGB
    this.count = 0;
    this.resolution = 0;
    this.synced = 0;  // voxels already copied into the mesh
  }

  // Appends v1.Voxel-like entries ({center: {x, y, z}, rgb}) up to the capacity.
  add(voxels, resolution) {
    this.resolution = resolution;
    for (const v of voxels) {
      if (this.count === this.capacity) break;
      const c = v.center;
      const i = this.count++;
      this.positions[3 * i] = c?.x || 0;
      this.positions[3 * i + 1] = c?.y || 0;
      this.positions[3 * i + 2] = c?.z || 0;
      this.colours[i] = v.rgb || 0;
    }
  }

  addArrays(positions, colours, resolution) {
    this.resolution = resolution;
    for (let i = 0; i < colours.length && this.count < this.capacity; i++) {
      const j = this.count++;
      this.positions[3 * j] = positions[3 * i];
      this.positions[3 * j + 1] = positions[3 * i + 1];
      this.positions[3 * j + 2] = positions[3 * i + 2];
      this.colours[j] = colours[i];
    }
  }

  // A new InstancedMesh of the voxels so far (room for the capacity).
  mesh() {
    const mesh = new THREE.InstancedMesh(
      new THREE.BoxGeometry(this.resolution, this.resolution, this.resolution),
      new THREE.MeshLambertMaterial(), this.capacity);
    mesh.count = 0;
    mesh.userData.colours = this.colours;
    this.synced = 0;
    this.sync(mesh);
    return mesh;
  }

  // Copies the voxels added since the last sync into `mesh` (made by mesh()).
  sync(mesh) {
    const m = new THREE.Matrix4();
    const c = new THREE.Color();
    for (let i = this.synced; i < this.count; i++) {
      m.makeTranslation(this.positions[3 * i], this.positions[3 * i + 1], this.positions[3 * i + 2]);
      mesh.setMatrixAt(i, m);
      const rgb = this.colours[i];
      c.setRGB(((rgb >> 16) & 255) / 255, ((rgb >> 8) & 255) / 255, (rgb & 255) / 255, THREE.SRGBColorSpace);
      mesh.setColorAt(i, c);
    }
    this.synced = this.count;
    mesh.count = this.count;
    mesh.instanceMatrix.needsUpdate = true;
    if (mesh.instanceColor) mesh.instanceColor.needsUpdate = true;
    mesh.computeBoundingSphere();
  }

  // A cloud of blocks of m x m x m voxels (on a grid anchored at the first voxel): each
  // non-empty block's centre of voxels and mean colour.
  coarsen(m) {
    const edge = this.resolution * m;
    const blocks = new Map();  // block index -> [sum x, y, z, r, g, b, n]
    const [ox, oy, oz] = [this.positions[0], this.positions[1], this.positions[2]];
    const SPAN = 1 << 20;
    for (let i = 0; i < this.count; i++) {
      const x = this.positions[3 * i], y = this.positions[3 * i + 1], z = this.positions[3 * i + 2];
      const key = ((Math.floor((x - ox) / edge) + SPAN / 2) * SPAN + (Math.floor((y - oy) / edge) + SPAN / 2)) * SPAN +
        (Math.floor((z - oz) / edge) + SPAN / 2);
      let b = blocks.get(key);
      if (!b) blocks.set(key, (b = [0, 0, 0, 0, 0, 0, 0]));
      const rgb = this.colours[i];
      b[0] += x; b[1] += y; b[2] += z;
      b[3] += (rgb >> 16) & 255; b[4] += (rgb >> 8) & 255; b[5] += rgb & 255; b[6]++;
    }
    const coarse = new VoxelCloud(blocks.size);
    coarse.resolution = edge;
    for (const b of blocks.values()) {
      const i = coarse.count++;
      const n = b[6];
      coarse.positions[3 * i] = b[0] / n;
      coarse.positions[3 * i + 1] = b[1] / n;
      coarse.positions[3 * i + 2] = b[2] / n;
      coarse.colours[i] = (Math.round(b[3] / n) << 16) | (Math.round(b[4] / n) << 8) | Math.round(b[5] / n);
    }
    return coarse;
  }
}

// Colours `mesh`'s instances by `colours` (0xRRGGBB), or grey: by their dimmed luminance and
// see-through.
function greyMesh(mesh, colours, grey) {
  const c = new THREE.Color();
  for (let i = 0; i < mesh.count; i++) {
    const rgb = colours[i];
    const r = (rgb >> 16) & 255, g = (rgb >> 8) & 255, b = rgb & 255;
    if (grey) {
      const y = (0.3 * (0.2126 * r + 0.7152 * g + 0.0722 * b) + 40) / 255;
      c.setRGB(y, y, y, THREE.SRGBColorSpace);
    } else {
      c.setRGB(r / 255, g / 255, b / 255, THREE.SRGBColorSpace);
    }
    mesh.setColorAt(i, c);
  }
  if (mesh.instanceColor) mesh.instanceColor.needsUpdate = true;
  const material = mesh.material;
  material.transparent = grey;
  material.opacity = grey ? 0.25 : 1;
  material.depthWrite = !grey;
  material.needsUpdate = true;
}

// One THREE.InstancedMesh of boxes of edge `edge` at `positions` (x, y, z, ...) with
// `colours` (0xRRGGBB, sRGB).
function instancedBoxes(positions, colours, edge) {
  const cloud = new VoxelCloud(colours.length);
  cloud.addArrays(positions, colours, edge);
  return cloud.mesh();
}

function disposeMesh(mesh) {
  mesh.geometry.dispose();
  mesh.material.dispose();
  mesh.dispose();
}

function label(text) {
  const canvas = document.createElement('canvas');
  const ctx = canvas.getContext('2d');
  ctx.font = '28px sans-serif';
  canvas.width = Math.ceil(ctx.measureText(text).width) + 12;
  canvas.height = 40;
  ctx.font = '28px sans-serif';
  ctx.fillStyle = 'rgba(0,0,0,0.6)';
  ctx.fillRect(0, 0, canvas.width, canvas.height);
  ctx.fillStyle = '#ffcc33';
  ctx.fillText(text, 6, 29);
  const sprite = new THREE.Sprite(new THREE.SpriteMaterial({ map: new THREE.CanvasTexture(canvas), depthTest: false }));
  sprite.scale.set(0.004 * canvas.width, 0.004 * canvas.height, 1);
  sprite.position.set(0, 0, 0.12);
  return sprite;
}
