// The HTTP API of `rigfit serve` (docs/serve-api.md), on the page's own origin.

export class ApiError extends Error {}

async function check(response) {
  if (response.ok) return response;
  let message = `${response.status} ${response.statusText}`;
  try {
    message = (await response.json()).error ?? message;
  } catch {
    // Not JSON: keep the status line.
  }
  throw new ApiError(message);
}

async function postJson(url, body) {
  return check(
    await fetch(url, {
      method: 'POST',
      headers: { 'Content-Type': 'application/json' },
      body: JSON.stringify(body),
    }),
  );
}

/** Every loaded CHARACTER. */
export async function listCharacters() {
  return (await (await check(await fetch('/api/characters'))).json()).characters;
}

/**
 * Uploads a .glb / .gltf / .bvh file (a File or Blob with a name); the new CHARACTER. The
 * server takes uploads only as `application/octet-stream` (or a glTF type): a browser's own
 * type for the file may be empty or `text/plain`, which the server refuses.
 */
export async function uploadCharacter(file) {
  const url = `/api/characters?name=${encodeURIComponent(file.name)}`;
  const headers = { 'Content-Type': 'application/octet-stream' };
  return (await check(await fetch(url, { method: 'POST', headers, body: file }))).json();
}

/** The GLB the page displays for a character. */
export function modelUrl(id) {
  return `/api/characters/${encodeURIComponent(id)}/model.glb`;
}

/** Solves a pose: { pose, strokes, bones?, method? } -> the pose report. */
export async function solve(id, request) {
  return (await postJson(`/api/characters/${encodeURIComponent(id)}/solve`, request)).json();
}

/** Exports a character: { format, fps, pose, keys } -> { blob, filename }. */
export async function exportCharacter(id, request) {
  const response = await postJson(`/api/characters/${encodeURIComponent(id)}/export`, request);
  const disposition = response.headers.get('Content-Disposition') ?? '';
  const match = /filename="?([^";]+)"?/.exec(disposition);
  const filename = match ? match[1] : `${id}.${request.format}`;
  return { blob: await response.blob(), filename };
}
