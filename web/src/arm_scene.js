// The arm in three.js, to scale: the base as the box of its inertia, links as rods between the
// joints, joints as spheres, each geared joint's rotor as a disc about the joint axis with a
// stripe that turns with the motor, and the end effector's path. A second run (--compare) is
// drawn as a ghost. In the plane the camera looks down z (pan and zoom); in 3D it orbits.
import * as THREE from 'three';
import { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';
import { STLLoader } from 'three/examples/jsm/loaders/STLLoader.js';
import { el } from './dom.js';

const COLORS = {
  base: 0x8a9bb0,
  link: [0x3b7dd8, 0xe07b39],
  joint: 0x222222,
  rotor: 0xc9a227,
  tip: 0xd62728,
  path: [0xd62728, 0x7f7f7f],
};

// Index k and weight w with t between times[k] and times[k + 1]; null outside [first, last].
export function bracket(times, t) {
  const n = times.length;
  if (!(t >= times[0] && t <= times[n - 1])) return null;
  let lo = 0, hi = n - 1;
  while (hi - lo > 1) {
    const mid = (lo + hi) >> 1;
    if (times[mid] <= t) lo = mid;
    else hi = mid;
  }
  if (lo === hi) return { k: lo, w: 0 };
  const span = times[hi] - times[lo];
  return { k: lo, w: span > 0 ? (t - times[lo]) / span : 0 };
}

// Row k of a frame array blended with row k + 1; with `quaternion` (its index), the second
// row's quaternion is taken on the first one's side (q and -q are the same turn).
function blend(rows, at, quaternion = -1) {
  const a = rows[at.k];
  if (at.w === 0 || at.k + 1 >= rows.length) return a.slice();
  let b = rows[at.k + 1];
  if (quaternion >= 0) {
    let dot = 0;
    for (let i = quaternion; i < quaternion + 4; ++i) dot += a[i] * b[i];
    if (dot < 0) b = b.map((v, i) => (i >= quaternion && i < quaternion + 4 ? -v : v));
  }
  return a.map((v, i) => v + (b[i] - v) * at.w);
}

// Row k of rows of poses [x y z qw qx qy qz]... blended with row k + 1, each quaternion on
// the first row's side.
function blendPoses(rows, at) {
  const a = rows[at.k];
  if (at.w === 0 || at.k + 1 >= rows.length) return a.slice();
  const b = rows[at.k + 1].slice();
  for (let p = 0; p < b.length; p += 7) {
    let dot = 0;
    for (let i = p + 3; i < p + 7; ++i) dot += a[i] * b[i];
    if (dot < 0) for (let i = p + 3; i < p + 7; ++i) b[i] = -b[i];
  }
  return a.map((v, i) => v + (b[i] - v) * at.w);
}

function rod(radius, color, opacity) {
  const material = new THREE.MeshStandardMaterial({ color, transparent: opacity < 1, opacity });
  const mesh = new THREE.Mesh(new THREE.CylinderGeometry(1, 1, 1, 20), material);
  mesh.userData.radius = radius;
  return mesh;
}

// Places a unit cylinder (axis y) from point a to point b.
function placeRod(mesh, a, b) {
  const d = new THREE.Vector3().subVectors(b, a);
  const length = d.length();
  mesh.visible = length > 0;
  if (!mesh.visible) return;
  mesh.position.copy(a).addScaledVector(d, 0.5);
  mesh.quaternion.setFromUnitVectors(new THREE.Vector3(0, 1, 0), d.normalize());
  const r = mesh.userData.radius;
  mesh.scale.set(r, length, r);
}

// A URDF <visual> shape (data.geometry.body_visuals[body]): a box, a cylinder along its z
// (three.js's are along y), a sphere, or an STL mesh (data.meshes, parsed once by three.js's
// STLLoader, scaled per axis), placed in its body's frame.
function visualMesh(v, material, meshes) {
  const [a, b, c] = v.size;
  const shape = v.kind === 'box' ? new THREE.BoxGeometry(a, b, c)
    : v.kind === 'cylinder' ? new THREE.CylinderGeometry(a, a, b, 32).rotateX(Math.PI / 2)
    : v.kind === 'mesh' ? meshes[v.mesh]
    : new THREE.SphereGeometry(a, 24, 16);
  const mesh = new THREE.Mesh(shape, material);
  if (v.kind === 'mesh') mesh.scale.set(a, b, c);
  mesh.position.set(...v.position);
  const [w, x, y, z] = v.quaternion;
  mesh.quaternion.set(x, y, z, w);
  return mesh;
}

// The page's STL meshes as three.js geometries (base64 in data.meshes).
export function stlGeometries(meshes) {
  const loader = new STLLoader();
  return (meshes || []).map((m) => {
    const bytes = Uint8Array.from(atob(m.stl), (ch) => ch.charCodeAt(0));
    const geometry = loader.parse(bytes.buffer);
    geometry.computeVertexNormals();
    return geometry;
  });
}

// A body's URDF shapes as one group in its frame.
function bodyGroup(shapes, material, meshes) {
  const group = new THREE.Group();
  for (const v of shapes || []) group.add(visualMesh(v, material, meshes));
  return group;
}

// Sets a group to a pose [x, y, z, qw, qx, qy, qz].
function placeGroup(group, pose, at = 0) {
  group.position.set(pose[at], pose[at + 1], pose[at + 2]);
  group.quaternion.set(pose[at + 4], pose[at + 5], pose[at + 6], pose[at + 3]).normalize();
}

// The rods of an arm, as pairs of point indices (joints 0..n-1, then the end effectors), and
// the joints a strut joins to the base: a chain's each joint to the next and the last to its
// tip; a tree's (geometry.segments, geometry.struts) each link to its children and end effectors.
function skeleton(geometry, run) {
  if (geometry.segments) return { n: geometry.num_joints, segments: geometry.segments,
                                  struts: geometry.struts };
  const n = run.points[0].length / 3 - 1;
  return { n, segments: Array.from({ length: n }, (_, i) => [i, i + 1]), struts: [0] };
}

// One run's meshes: base, mount struts, links, joints, rotors and tips; a URDF's shapes on the
// base and on each link where it gives them (the rods and joints stay: the kinematic tree).
class ArmMeshes {
  constructor(scene, geometry, run, ghost, meshes) {
    this.run = run;
    const { n, segments, struts } = skeleton(geometry, run);
    this.n = n;
    this.segments = segments;
    this.strutJoints = struts;
    this.numTips = run.points[0].length / 3 - n;
    const opacity = ghost ? 0.35 : 1;
    const material = (color) =>
      new THREE.MeshStandardMaterial({ color, transparent: ghost, opacity });
    const [a, b, c] = geometry.base_box;
    this.base = new THREE.Mesh(new THREE.BoxGeometry(a, b, c), material(COLORS.base));
    this.baseCenter = new THREE.Vector3(...geometry.base_center);
    // A URDF base's own shapes (in the base frame), drawn instead of the inertia box.
    const visuals = geometry.body_visuals || [];
    this.shapes = bodyGroup(visuals[0], material(COLORS.base), meshes);
    const shaped = this.shapes.children.length > 0;
    // Each link's own shapes, placed by the run's body frames.
    this.linkShapes = run.bodies
      ? visuals.slice(1).map((list, i) =>
        bodyGroup(list, material(COLORS.link[ghost ? 1 : 0] + (i % 2) * 0x101010), meshes))
      : [];
    this.base.visible = !shaped;
    this.struts = struts.map(() => rod(geometry.joint_radius * 0.6, COLORS.base, opacity));
    this.links = segments.map(([a], i) =>
      rod(geometry.link_radius[Math.min(a, n - 1)], COLORS.link[ghost ? 1 : 0] + (i % 2) * 0x101010,
          opacity));
    const sphere = new THREE.SphereGeometry(geometry.joint_radius, 20, 14);
    this.joints = Array.from({ length: n }, () => new THREE.Mesh(sphere, material(COLORS.joint)));
    const tipSphere = new THREE.SphereGeometry(geometry.joint_radius * 0.9, 20, 14);
    this.tips = Array.from({ length: this.numTips },
                           () => new THREE.Mesh(tipSphere, material(COLORS.tip)));
    this.tip = this.tips[0];
    this.rotors = geometry.rotors.map((present) =>
      present && !ghost && run.rotor ? this.rotorMesh(geometry.rotor_radius) : null);
    this.group = new THREE.Group();
    this.group.add(this.base, this.shapes, ...this.struts, ...this.links, ...this.joints,
                   ...this.tips, ...this.linkShapes);
    for (const r of this.rotors) if (r) this.group.add(r);
    scene.add(this.group);
  }

  rotorMesh(radius) {
    const group = new THREE.Group();
    const disc = new THREE.Mesh(new THREE.CylinderGeometry(radius, radius, radius * 0.35, 32),
                                new THREE.MeshStandardMaterial({ color: COLORS.rotor }));
    const stripe = new THREE.Mesh(new THREE.BoxGeometry(radius * 1.9, radius * 0.4, radius * 0.25),
                                  new THREE.MeshStandardMaterial({ color: 0x222222 }));
    stripe.position.y = 0.0;
    group.add(disc, stripe);
    return group;
  }

  // Draws the run at time t; hidden outside its time range.
  show(t) {
    const at = bracket(this.run.t, t);
    this.group.visible = at !== null;
    if (!at) return;
    const p = blend(this.run.points, at);
    const point = (i) => new THREE.Vector3(p[3 * i], p[3 * i + 1], p[3 * i + 2]);
    const pose = blend(this.run.base, at, 3);
    const q = new THREE.Quaternion(pose[4], pose[5], pose[6], pose[3]).normalize();
    const origin = new THREE.Vector3(pose[0], pose[1], pose[2]);
    this.base.quaternion.copy(q);
    this.base.position.copy(this.baseCenter).applyQuaternion(q).add(origin);
    this.shapes.quaternion.copy(q);
    this.shapes.position.copy(origin);
    this.strutJoints.forEach((j, k) => placeRod(this.struts[k], this.base.position, point(j)));
    this.segments.forEach(([a, b], k) => placeRod(this.links[k], point(a), point(b)));
    for (let i = 0; i < this.n; ++i) this.joints[i].position.copy(point(i));
    this.tips.forEach((tip, e) => tip.position.copy(point(this.n + e)));
    if (this.linkShapes.length) {
      const frames = blendPoses(this.run.bodies, at);
      this.linkShapes.forEach((group, i) => placeGroup(group, frames, 7 * (i + 1)));
    }
    const axes = this.run.axes ? blend(this.run.axes, at) : null;
    const angles = this.run.rotor ? blend(this.run.rotor, at) : null;
    this.rotors.forEach((rotor, i) => {
      if (!rotor) return;
      const axis = axes ? new THREE.Vector3(axes[3 * i], axes[3 * i + 1], axes[3 * i + 2])
                        : new THREE.Vector3(0, 0, 1);
      const next = this.segments.find(([a]) => a === i);  // the link's first rod
      placeRotor(rotor, point(i), axis.normalize(), point(next ? next[1] : i + 1), angles[i]);
    });
  }
}

// A rotor at joint point a, about axis, its stripe turned by angle (the motor's angle relative
// to the link) from the link's direction towards the next joint b.
function placeRotor(rotor, a, axis, b, angle) {
  const u = new THREE.Vector3().subVectors(b, a);
  u.addScaledVector(axis, -u.dot(axis));
  if (u.lengthSq() < 1e-18) {  // the next joint on the axis: any direction across it
    u.set(Math.abs(axis.x) < 0.9 ? 1 : 0, Math.abs(axis.x) < 0.9 ? 0 : 1, 0);
    u.addScaledVector(axis, -u.dot(axis));
  }
  u.normalize();
  const v = new THREE.Vector3().crossVectors(axis, u);
  const d = u.clone().multiplyScalar(Math.cos(angle)).addScaledVector(v, Math.sin(angle));
  const z = new THREE.Vector3().crossVectors(d, axis);
  rotor.quaternion.setFromRotationMatrix(new THREE.Matrix4().makeBasis(d, axis, z));
  rotor.position.copy(a);
}

// Each end effector's path over the whole run (the points after the n joints).
function pathLines(run, n, color) {
  const lines = [];
  for (let at = 3 * n; at < run.points[0].length; at += 3) {
    const positions = new Float32Array(run.points.length * 3);
    run.points.forEach((p, k) => positions.set(p.slice(at, at + 3), 3 * k));
    const geometry = new THREE.BufferGeometry();
    geometry.setAttribute('position', new THREE.BufferAttribute(positions, 3));
    lines.push(new THREE.Line(geometry, new THREE.LineBasicMaterial({ color })));
  }
  return lines;
}

export class ArmScene {
  constructor(parent, data) {
    this.planar = data.space === 'planar';
    this.box = el('div', 'scene3d');
    parent.append(this.box);
    this.renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
    this.renderer.setPixelRatio(window.devicePixelRatio || 1);
    this.box.append(this.renderer.domElement);
    this.scene = new THREE.Scene();
    this.scene.background = new THREE.Color(0xf7f7f4);
    this.scene.add(new THREE.AmbientLight(0xffffff, 1.2));
    const sun = new THREE.DirectionalLight(0xffffff, 2.0);
    sun.position.set(2, -3, 5);
    this.scene.add(sun);
    const meshes = stlGeometries(data.meshes);
    this.arms = data.runs.map((run, i) =>
      new ArmMeshes(this.scene, data.geometry, run, i > 0, meshes));
    data.runs.forEach((run, i) => this.scene.add(
      ...pathLines(run, skeleton(data.geometry, run).n, COLORS.path[Math.min(i, 1)])));
    this.setCamera(data);
    this.fitButtons(parent);
    if (((data.geometry.body_visuals || [])[0] || []).length) this.boxToggle(parent);
    new ResizeObserver(() => this.resize()).observe(this.box);
    this.resize();
  }

  // The two framings (data.camera.fit picks the first, buttons switch): "all", every run's
  // points, bases and shapes; "arm", the arm's joints and tip over the run (a satellite far
  // larger than its arm then leaves the arm in view). The plane seen from above, 3D from an
  // oblique corner, or from data.camera.eye towards its target (default the arm's centre).
  setCamera(data) {
    const all = new THREE.Box3(), arm = new THREE.Box3();
    for (const run of data.runs)
      for (let k = 0; k < run.points.length; ++k) {
        const p = run.points[k];
        for (let i = 0; i < p.length; i += 3) arm.expandByPoint(new THREE.Vector3(p[i], p[i + 1], p[i + 2]));
        all.expandByPoint(new THREE.Vector3(run.base[k][0], run.base[k][1], run.base[k][2]));
      }
    all.union(arm);
    const shaped = ((data.geometry.body_visuals || [])[0] || []).length > 0;
    all.expandByScalar(shaped ? 0 : Math.max(...data.geometry.base_box) * 0.75);
    for (const a of this.arms) {
      a.show(a.run.t[0]);
      if (shaped) all.expandByObject(a.shapes);
      for (const group of a.linkShapes) { all.expandByObject(group); arm.expandByObject(group); }
    }
    arm.expandByScalar(data.geometry.joint_radius * 2);
    this.fits = { all, arm };
    const camera = data.camera || { fit: 'all' };
    const size = all.getSize(new THREE.Vector3()).length();
    if (this.planar) {
      this.camera = new THREE.OrthographicCamera(-1, 1, 1, -1, -100 * size, 100 * size);
    } else {
      this.camera = new THREE.PerspectiveCamera(40, 1, size / 1000, size * 100);
      this.camera.up.set(0, 0, 1);
      const grid = new THREE.GridHelper(size * 2, 20, 0xbbbbbb, 0xdddddd);
      grid.rotation.x = Math.PI / 2;
      const center = all.getCenter(new THREE.Vector3());
      grid.position.set(center.x, center.y, all.min.z);
      this.scene.add(grid);
    }
    this.controls = new OrbitControls(this.camera, this.renderer.domElement);
    this.controls.enableRotate = !this.planar;
    if (this.planar) this.controls.screenSpacePanning = true;
    this.controls.addEventListener('change', () => this.render());
    this.fit(camera.fit === 'arm' ? 'arm' : 'all');
    if (camera.eye) {
      const target = camera.target ? new THREE.Vector3(...camera.target)
        : arm.getCenter(new THREE.Vector3());
      this.camera.position.set(...camera.eye);
      this.controls.target.copy(target);
      this.controls.update();
    }
  }

  // Frames `name` ("all" or "arm") from the default direction.
  fit(name) {
    const box = this.fits[name];
    const center = box.getCenter(new THREE.Vector3());
    const size = Math.max(box.getSize(new THREE.Vector3()).length(), 1e-6);
    this.extent = size;
    this.framed = name;
    if (this.planar) this.camera.position.set(center.x, center.y, this.fits.all.getSize(new THREE.Vector3()).length());
    else this.camera.position.copy(center).add(new THREE.Vector3(0.55, -0.8, 0.5).multiplyScalar(size));
    this.controls.target.copy(center);
    this.controls.update();
    if (this.box.clientWidth) this.resize();
  }

  // Buttons that frame the whole scene or the arm alone.
  fitButtons(parent) {
    const row = el('div', 'note');
    for (const [name, text] of [['all', 'fit all'], ['arm', 'fit the arm']]) {
      const button = el('button');
      button.textContent = text;
      button.dataset.fit = name;
      button.addEventListener('click', () => this.fit(name));
      row.append(button, document.createTextNode(' '));
    }
    parent.append(row);
  }

  // A URDF base is drawn with its own shapes; this shows the box of its inertia beside them.
  boxToggle(parent) {
    const label = el('label', 'note');
    const box = document.createElement('input');
    box.type = 'checkbox';
    box.addEventListener('change', () => {
      for (const arm of this.arms) arm.base.visible = box.checked;
      this.render();
    });
    label.append(box, document.createTextNode(' the base as the box of its inertia too'));
    parent.append(label);
    this.inertiaBoxToggle = box;
  }

  resize() {
    const w = Math.max(1, this.box.clientWidth), h = Math.max(1, this.box.clientHeight);
    this.renderer.setSize(w, h);
    if (this.planar) {
      const half = this.extent / 2, aspect = w / h;
      Object.assign(this.camera, { left: -half * aspect, right: half * aspect, top: half, bottom: -half });
    } else {
      this.camera.aspect = w / h;
    }
    this.camera.updateProjectionMatrix();
    this.render();
  }

  show(t) {
    for (const arm of this.arms) arm.show(t);
    this.render();
  }

  render() {
    this.renderer.render(this.scene, this.camera);
  }

  // How run 0's base is drawn: its URDF shapes, and whether the inertia box shows; its links'
  // shapes (count per link) and where each link's shapes sit in the world.
  baseShapes() {
    const arm = this.arms[0];
    return {
      shapes: arm.shapes.children.length,
      box: arm.base.visible,
      links: arm.linkShapes.map((g) => g.children.length),
      linkPositions: arm.linkShapes.map((g) => g.position.toArray()),
      jointPositions: arm.joints.map((j) => j.position.toArray()),
      meshTriangles: arm.linkShapes.flatMap((g) => g.children)
        .filter((m) => m.geometry.type === 'BufferGeometry')
        .map((m) => m.geometry.attributes.position.count / 3),
    };
  }

  // The framing shown ("all" or "arm") and the camera's position and target.
  view() {
    return { framed: this.framed, position: this.camera.position.toArray(),
             target: this.controls.target.toArray() };
  }

  // The drawn end effector of run i: [x, y, z], or null where the run is hidden.
  endEffector(i) {
    const arm = this.arms[i];
    if (!arm || !arm.group.visible) return null;
    return arm.tip.position.toArray();
  }

  // Every drawn end effector of run i (a tree's several), or null where the run is hidden; and
  // the rods drawn.
  endEffectors(i) {
    const arm = this.arms[i];
    if (!arm || !arm.group.visible) return null;
    return { tips: arm.tips.map((t) => t.position.toArray()), rods: arm.links.length,
             struts: arm.struts.length };
  }
}
