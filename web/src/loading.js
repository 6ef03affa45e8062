// Loading from the server: JSON with the server's error messages, and the scene's GLB
// with download progress.

import { GLTFLoader } from "three/addons/loaders/GLTFLoader.js";

/** GETs `url` as JSON; a failure throws an Error naming `what`, with the server's message, `status` and `code`. */
export async function fetchJson(url, what) {
  let r;
  try {
    r = await fetch(url);
  } catch (e) {
    throw new Error(`cannot reach the homcull server at ${location.origin} (${e.message}); is it running?`);
  }
  let body = null;
  try {
    body = await r.json();
  } catch {
    /* not JSON */
  }
  if (!r.ok) {
    const msg = body?.error?.message ?? `HTTP ${r.status}`;
    const err = new Error(`${what}: ${msg}`);
    err.status = r.status;
    err.code = body?.error?.code;
    throw err;
  }
  return body;
}

/** Fetches and parses a GLB, reporting `onProgress(bytes, total)` while it downloads. */
export async function loadGlb(url, onProgress) {
  let r;
  try {
    r = await fetch(url);
  } catch (e) {
    throw new Error(`cannot reach the homcull server at ${location.origin} (${e.message})`);
  }
  if (!r.ok) {
    let msg = `HTTP ${r.status}`;
    try {
      msg = (await r.json()).error.message;
    } catch {
      /* keep the status */
    }
    throw new Error(`scene GLB: ${msg}`);
  }
  const total = Number(r.headers.get("content-length")) || 0;
  let buffer;
  if (r.body && total) {
    const reader = r.body.getReader();
    const out = new Uint8Array(total);
    let got = 0;
    for (;;) {
      const { done, value } = await reader.read();
      if (done) break;
      if (got + value.length > out.length) throw new Error("scene GLB is longer than its Content-Length");
      out.set(value, got);
      got += value.length;
      onProgress(got, total);
    }
    buffer = out.buffer.slice(0, got);
  } else {
    buffer = await r.arrayBuffer();
  }
  return new GLTFLoader().parseAsync(buffer, "");
}
