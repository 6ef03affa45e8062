// Object IDs of an arbitrary glTF hierarchy, mapped the way the server numbers them
// (depth-first pre-order over the default scene, mesh-bearing nodes only), with
// GLTFLoader run in Node on a hand-made GLB.

import { test } from "node:test";
import assert from "node:assert/strict";

import * as THREE from "three";
import { GLTFLoader } from "three/addons/loaders/GLTFLoader.js";

import { flatten, mapObjects, meshNodeOrder, walkStart } from "../src/scene-map.js";

function glb(json, bin) {
  const enc = new TextEncoder();
  let jsonBytes = enc.encode(JSON.stringify(json));
  const pad = (b, fill) => {
    const n = Math.ceil(b.length / 4) * 4;
    const out = new Uint8Array(n).fill(fill);
    out.set(b);
    return out;
  };
  jsonBytes = pad(jsonBytes, 0x20);
  const binBytes = pad(bin, 0);
  const total = 12 + 8 + jsonBytes.length + 8 + binBytes.length;
  const out = new Uint8Array(total);
  const v = new DataView(out.buffer);
  v.setUint32(0, 0x46546c67, true);
  v.setUint32(4, 2, true);
  v.setUint32(8, total, true);
  v.setUint32(12, jsonBytes.length, true);
  v.setUint32(16, 0x4e4f534a, true);
  out.set(jsonBytes, 20);
  const o = 20 + jsonBytes.length;
  v.setUint32(o, binBytes.length, true);
  v.setUint32(o + 4, 0x004e4942, true);
  out.set(binBytes, o + 8);
  return out.buffer;
}

// One triangle, shared by every primitive.
const positions = new Float32Array([0, 0, 0, 1, 0, 0, 0, 1, 0]);
const base = {
  asset: { version: "2.0" },
  buffers: [{ byteLength: positions.byteLength }],
  bufferViews: [{ buffer: 0, byteLength: positions.byteLength }],
  accessors: [{ bufferView: 0, componentType: 5126, count: 3, type: "VEC3", min: [0, 0, 0], max: [1, 1, 0] }],
  meshes: [
    { name: "one", primitives: [{ attributes: { POSITION: 0 } }] },
    { name: "two", primitives: [{ attributes: { POSITION: 0 } }, { attributes: { POSITION: 0 }, mode: 1 }] },
    { name: "three", primitives: [{ attributes: { POSITION: 0 } }] },
  ],
  scene: 0,
  scenes: [{ nodes: [0, 7] }],
  nodes: [
    /* 0 */ { name: "root", translation: [100, 0, 0], children: [1, 4] },
    /* 1 */ { name: "a", mesh: 0, translation: [0, 10, 0], children: [2, 3] },
    /* 2 */ { name: "b", mesh: 1, translation: [0, 0, 5] },
    /* 3 */ { name: "c", mesh: 0, scale: [2, 2, 2] },
    /* 4 */ { name: "empty", children: [5] },
    /* 5 */ { name: "d", mesh: 2, translation: [1, 2, 3] },
    /* 6 */ { name: "orphan", mesh: 0 },
    /* 7 */ { name: "e", mesh: 2 },
  ],
};

async function load(json) {
  const loader = new GLTFLoader();
  return loader.parseAsync(glb(json, new Uint8Array(positions.buffer)), "");
}

test("meshNodeOrder walks the default scene depth-first, mesh nodes only", () => {
  assert.deepEqual(meshNodeOrder(base), [1, 2, 3, 5, 7]);
  assert.deepEqual(meshNodeOrder({ ...base, scene: undefined }), [1, 2, 3, 5, 7]);
  assert.deepEqual(meshNodeOrder({ ...base, scene: 1, scenes: [{ nodes: [] }, { nodes: [6, 4] }] }), [6, 5]);
  assert.deepEqual(meshNodeOrder({ nodes: [] }), []);
});

test("mapObjects maps each ID to all of its node's primitives and nothing else", async () => {
  const gltf = await load(base);
  const { meshesById, nodeOrder, warnings } = mapObjects(gltf);
  assert.deepEqual(warnings, []);
  assert.deepEqual(nodeOrder, [1, 2, 3, 5, 7]);
  assert.deepEqual(meshesById.map((m) => m.length), [1, 2, 1, 1, 1]);
  assert.deepEqual(meshesById.map((ms) => ms.map((m) => m.isLine === true)), [[false], [false, true], [false], [false], [false]]);
  assert.equal(meshesById[0][0].name, "a");
  assert.equal(meshesById[2][0].name, "c");
  assert.equal(meshesById[3][0].name, "d");
  assert.equal(meshesById[4][0].name, "e");
  const all = meshesById.flat();
  assert.equal(new Set(all).size, all.length, "no object belongs to two IDs");
});

test("flatten keeps world transforms and makes hiding one ID independent of the hierarchy", async () => {
  const gltf = await load(base);
  const { meshesById } = mapObjects(gltf);
  gltf.scene.updateMatrixWorld(true);
  const before = meshesById.map((ms) => ms.map((m) => m.matrixWorld.clone()));
  const root = new THREE.Group();
  flatten(gltf.scene, meshesById, root);
  meshesById.forEach((ms, id) =>
    ms.forEach((m, k) => {
      assert.equal(m.parent, root);
      assert.equal(m.userData.homcullId, id);
      const a = m.matrixWorld.elements;
      const b = before[id][k].elements;
      a.forEach((x, i) => assert.ok(Math.abs(x - b[i]) < 1e-9, `id ${id} matrix`));
    }),
  );
  // World position of "c": root (100,0,0) + a (0,10,0), scale 2.
  const c = new THREE.Vector3().setFromMatrixPosition(meshesById[2][0].matrixWorld);
  assert.deepEqual(c.toArray(), [100, 10, 0]);
  // Hiding "a" (which had "b" and "c" as children) leaves them drawn.
  for (const m of meshesById[0]) m.visible = false;
  const drawn = [];
  root.traverseVisible((o) => o.userData.homcullId !== undefined && drawn.push(o.userData.homcullId));
  assert.deepEqual([...new Set(drawn)].sort(), [1, 2, 3, 4]);
});

test("walkStart turns the server's start hint into a position and a yaw", () => {
  const at = (look_at) => walkStart({ start: { position: [1, 1.7, 2], look_at } });
  const near = (a, b) => Math.abs(a - b) < 1e-9;
  assert.deepEqual(at([11, 1.7, 2]).position, [1, 1.7, 2]);
  assert.ok(near(at([11, 1.7, 2]).yawDeg, -90), "+X is yaw -90");
  assert.ok(near(at([1, 1.7, -8]).yawDeg, 0), "-Z is yaw 0");
  assert.ok(near(at([-9, 1.7, 2]).yawDeg, 90), "-X is yaw 90");
  assert.ok(near(Math.abs(at([1, 1.7, 12]).yawDeg), 180), "+Z is yaw ±180");
  assert.equal(walkStart({ id: "x" }), null, "no hint");
  assert.equal(at([1, 5, 2]), null, "straight up gives no direction");
  assert.equal(walkStart({ start: { position: [1, 2], look_at: [0, 0, 0] } }), null, "malformed");
  assert.equal(walkStart({ start: { position: [NaN, 0, 0], look_at: [0, 0, 0] } }), null, "not finite");
});
