// Vite builds the viewer into web/dist, which skimapd serves at / (--web_root).
// `npm run dev` serves it with hot reload and forwards the API to a local skimapd.
import { defineConfig } from 'vite';

export default defineConfig({
  base: '/',
  build: { outDir: 'dist', emptyOutDir: true, chunkSizeWarningLimit: 1000 },
  server: { proxy: { '/v1': 'http://127.0.0.1:8080', '/healthz': 'http://127.0.0.1:8080' } },
});
