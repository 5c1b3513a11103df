// Builds the dashboard into the Python package (src/bim2rdt/server/static), which commits the built files:
// `make web` runs this. Nothing is loaded from elsewhere at run time.
import { defineConfig } from "vite";

export default defineConfig({
  root: ".",
  base: "/",
  build: {
    outDir: "../src/bim2rdt/server/static",
    emptyOutDir: true,
    assetsDir: "assets",
    chunkSizeWarningLimit: 800,
    modulePreload: { polyfill: false },
  },
});
