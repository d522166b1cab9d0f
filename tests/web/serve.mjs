// A static file server on 127.0.0.1 for the web viewer's test: module scripts and fetch() need
// http, not file://. GET and HEAD of regular files under one directory; anything else 404/405.

import fs from 'node:fs';
import http from 'node:http';
import path from 'node:path';

const TYPES = {
  '.html': 'text/html; charset=utf-8',
  '.js': 'text/javascript; charset=utf-8',
  '.mjs': 'text/javascript; charset=utf-8',
  '.json': 'application/json',
  '.gltf': 'model/gltf+json',
  '.glb': 'model/gltf-binary',
  '.bin': 'application/octet-stream',
  '.png': 'image/png',
  '.jpg': 'image/jpeg',
  '.jpeg': 'image/jpeg',
  '.webp': 'image/webp',
  '.exr': 'image/x-exr',
};

// Resolves to { url: 'http://127.0.0.1:PORT/', requests: [paths asked for], completed: Set of
// paths sent whole with status 200, close() }.
export function serveDirectory(root) {
  const base = path.resolve(root);
  const requests = [];
  const completed = new Set();
  const server = http.createServer((request, response) => {
    const pathname = decodeURIComponent(new URL(request.url, 'http://localhost').pathname);
    requests.push(pathname);
    if (request.method !== 'GET' && request.method !== 'HEAD') {
      response.writeHead(405).end();
      return;
    }
    const file = path.join(base, path.normalize(pathname.endsWith('/') ? `${pathname}index.html`
                                                                      : pathname));
    if (file !== base && !file.startsWith(base + path.sep)) {
      response.writeHead(403).end();
      return;
    }
    fs.stat(file, (error, stat) => {
      if (error || !stat.isFile()) {
        response.writeHead(404, { 'Content-Type': 'text/plain' }).end('not found\n');
        return;
      }
      response.writeHead(200, {
        'Content-Type': TYPES[path.extname(file).toLowerCase()] ?? 'application/octet-stream',
        'Content-Length': stat.size,
        'Cache-Control': 'no-store',
      });
      response.on('finish', () => completed.add(pathname));
      if (request.method === 'HEAD') {
        response.end();
      } else {
        fs.createReadStream(file).pipe(response);
      }
    });
  });
  return new Promise((resolve, reject) => {
    server.once('error', reject);
    server.listen(0, '127.0.0.1', () => {
      const { port } = server.address();
      let closed = null;
      resolve({
        url: `http://127.0.0.1:${port}/`,
        requests,
        completed,
        // Stops listening, ends idle keep-alive connections at once and any other after 2 s.
        close: () => {
          closed ??= new Promise((done) => {
            server.close(() => done());
            server.closeIdleConnections();
            setTimeout(() => server.closeAllConnections(), 2000).unref();
          });
          return closed;
        },
      });
    });
  });
}
