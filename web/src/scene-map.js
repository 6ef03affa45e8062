// Object IDs of a glTF scene, as the server numbers them, mapped to three.js objects.
//
// The server numbers the mesh-bearing nodes of the default scene (else the first) in
// depth-first pre-order over the scene's node list, children in order, from 0; a node
// counts once however its mesh is shared. GLTFLoader's `parser.associations` tells which
// three.js object stands for which node; a node's mesh may be a single Mesh or a Group of
// primitives, all of which belong to the node's ID.

/** Node indices of the mesh-bearing nodes of the default scene, in server ID order. */
export function meshNodeOrder(json) {
  const scenes = json.scenes ?? [];
  const sceneIndex = json.scene ?? 0;
  const scene = scenes[sceneIndex] ?? scenes[0];
  if (!scene) return [];
  const nodes = json.nodes ?? [];
  const order = [];
  const stack = (scene.nodes ?? []).slice().reverse();
  let guard = 0;
  while (stack.length) {
    const index = stack.pop();
    const node = nodes[index];
    if (!node) continue;
    if (++guard > 10_000_000) throw new Error("glTF node hierarchy has a cycle");
    if (node.mesh !== undefined) order.push(index);
    const children = node.children ?? [];
    for (let i = children.length - 1; i >= 0; i--) stack.push(children[i]);
  }
  return order;
}

const isRenderable = (o) => Boolean(o.isMesh || o.isLine || o.isPoints || o.isSprite);

/**
 * Maps server object IDs to the three.js objects of a loaded glTF (`gltf` as GLTFLoader
 * resolves it). Returns `{ meshesById, nodeOrder, warnings }` where `meshesById[id]` is
 * the array of renderable objects (Mesh, Line, Points) drawing object `id`.
 */
export function mapObjects(gltf) {
  const json = gltf.parser.json;
  const assoc = gltf.parser.associations;
  const nodeOrder = meshNodeOrder(json);
  const nodeOf = (o) => assoc.get(o)?.nodes;
  const warnings = [];

  // Node objects with a mesh, in three.js pre-order (children: mesh parts, then child nodes).
  const nodeObjects = [];
  gltf.scene.traverse((o) => {
    const n = nodeOf(o);
    if (n !== undefined && json.nodes?.[n]?.mesh !== undefined) nodeObjects.push(o);
  });
  let objectForId;
  if (nodeObjects.length === nodeOrder.length && nodeObjects.every((o, i) => nodeOf(o) === nodeOrder[i])) {
    objectForId = nodeObjects;
  } else {
    warnings.push("three.js node order differs from the glTF order; mapping by node index");
    const byNode = new Map();
    for (const o of nodeObjects) if (!byNode.has(nodeOf(o))) byNode.set(nodeOf(o), o);
    objectForId = nodeOrder.map((n) => byNode.get(n));
  }

  const meshesById = objectForId.map((root, id) => {
    const out = [];
    if (!root) {
      warnings.push(`object ${id} (node ${nodeOrder[id]}) has no three.js object`);
      return out;
    }
    // The node's own renderables: the node itself, or its descendants not under another node.
    const visit = (o, isRoot) => {
      if (!isRoot && nodeOf(o) !== undefined) return;
      if (isRenderable(o)) out.push(o);
      for (const c of o.children) visit(c, false);
    };
    visit(root, true);
    return out;
  });
  return { meshesById, nodeOrder, warnings };
}

/**
 * Moves every renderable of `meshesById` under `root`, keeping world transforms, so that
 * hiding one object (`mesh.visible = false`) never hides another that was its child in
 * the glTF hierarchy. Tags each with `userData.homcullId`.
 */
export function flatten(gltfScene, meshesById, root) {
  gltfScene.updateMatrixWorld(true);
  meshesById.forEach((meshes, id) => {
    for (const m of meshes) {
      m.userData.homcullId = id;
    }
  });
  for (const meshes of meshesById) {
    for (const m of meshes) root.attach(m);
  }
  root.updateMatrixWorld(true);
  return root;
}

/**
 * Where to start walking in a scene: the server's `start` hint (a street-level eye and a
 * point it looks at) as a position and a yaw in degrees about +Y from −Z (−90 looks
 * along +X), or null when the scene has none or it is malformed.
 */
export function walkStart(info) {
  const start = info?.start;
  const ok = (v) => Array.isArray(v) && v.length === 3 && v.every(Number.isFinite);
  if (!start || !ok(start.position) || !ok(start.look_at)) return null;
  const dx = start.look_at[0] - start.position[0];
  const dz = start.look_at[2] - start.position[2];
  if (dx === 0 && dz === 0) return null;
  const yawDeg = (Math.atan2(-dx, -dz) * 180) / Math.PI;
  return { position: start.position.slice(), yawDeg };
}
