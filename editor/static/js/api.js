// The editor's calls to its server (/api, see docs/editor.md): every answer is JSON or a PNG.

export class ApiError extends Error {
  constructor(status, data) {
    super(data && data.error ? data.error : `HTTP ${status}`);
    this.status = status;
    this.field = data ? data.field : null;
  }
}

async function answer(res) {
  const data = res.headers.get('content-type')?.includes('json') ? await res.json() : null;
  if (!res.ok) throw new ApiError(res.status, data);
  return data;
}

export async function getJSON(url) {
  return answer(await fetch(url, { cache: 'no-store' }));
}

export async function sendJSON(method, url, body, headers = {}) {
  return answer(await fetch(url, { method, headers: { 'Content-Type': 'application/json', ...headers }, body: JSON.stringify(body) }));
}

/** GET JSON with the response's ETag: {data, etag}. */
export async function getVersioned(url) {
  const res = await fetch(url, { cache: 'no-store' });
  return { data: await answer(res), etag: res.headers.get('ETag') };
}

/** PUT JSON only if the resource is still at version etag; returns the new ETag. */
export async function putVersioned(url, body, etag) {
  const res = await fetch(url, { method: 'PUT', headers: { 'Content-Type': 'application/json', ...(etag ? { 'If-Match': etag } : {}) },
    body: JSON.stringify(body) });
  await answer(res);
  return res.headers.get('ETag');
}

/** Send a file's bytes as the body (only if the saved shot is still at version etag, when given). */
export async function sendBytes(method, url, blob, etag = null) {
  return answer(await fetch(url, { method, headers: { 'Content-Type': 'application/octet-stream', ...(etag ? { 'If-Match': etag } : {}) },
    body: blob }));
}

export async function putPNG(url, blob) {
  return answer(await fetch(url, { method: 'PUT', headers: { 'Content-Type': 'image/png' }, body: blob }));
}

/** An image element once loaded; rejects on 404 and the like. */
export function loadImage(url) {
  return new Promise((resolve, reject) => {
    const img = new Image();
    img.onload = () => resolve(img);
    img.onerror = () => reject(new Error(`cannot load ${url}`));
    img.src = url;
  });
}

/** POST JSON, receive raw 8-bit RGBA rows (X-Width x X-Height): {bitmap, headers}. No image decoding. */
export async function postForPixels(url, body) {
  const res = await fetch(url, { method: 'POST', headers: { 'Content-Type': 'application/json' }, body: JSON.stringify({ ...body, format: 'rgba' }) });
  if (!res.ok) await answer(res);
  const w = +res.headers.get('X-Width'), h = +res.headers.get('X-Height');
  const pixels = new Uint8ClampedArray(await res.arrayBuffer());
  return { bitmap: await createImageBitmap(new ImageData(pixels, w, h)), headers: res.headers };
}
