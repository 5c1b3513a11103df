// Builds the dashboard into the Python package (src/bim2rdt/server/static), which commits the built files:
// `make web` runs this. Nothing is loaded from elsewhere at run time.
import { copyFileSync, mkdirSync } from "node:fs";
import { createRequire } from "node:module";
import { dirname, join } from "node:path";
import { defineConfig } from "vite";

const SWAGGER_FILES = ["swagger-ui-bundle.js", "swagger-ui.css", "swagger-ui-bundle.js.LICENSE.txt", "LICENSE",
                       "NOTICE"];

// The API docs page (/docs) runs Swagger UI from the npm package swagger-ui-dist (its prebuilt bundle, as
// published, with its licence files), plus docs/swagger-init.js: copied into static/swagger after the build.
function swaggerUi() {
  const dist = dirname(createRequire(import.meta.url).resolve("swagger-ui-dist/package.json"));
  return {
    name: "bim2rdt-swagger-ui",
    writeBundle(options) {
      const target = join(options.dir, "swagger");
      mkdirSync(target, { recursive: true });
      for (const name of SWAGGER_FILES) copyFileSync(join(dist, name), join(target, name));
      copyFileSync("docs/swagger-init.js", join(target, "swagger-init.js"));
    },
  };
}

export default defineConfig({
  root: ".",
  base: "/",
  plugins: [swaggerUi()],
  build: {
    outDir: "../src/bim2rdt/server/static",
    emptyOutDir: true,
    assetsDir: "assets",
    chunkSizeWarningLimit: 800,
    modulePreload: { polyfill: false },
  },
});
