// Starts Swagger UI on the API docs page (/docs): the spec URL comes from the page, so no inline script is needed
// and the page's Content-Security-Policy can allow this server's own scripts only. validatorUrl is off: Swagger
// UI would otherwise send the spec's URL to validator.swagger.io and show its badge from there.
const root = document.getElementById("swagger-ui");
window.ui = SwaggerUIBundle({
  url: root.dataset.spec,
  dom_id: "#swagger-ui",
  layout: "BaseLayout",
  deepLinking: true,
  showExtensions: true,
  showCommonExtensions: true,
  validatorUrl: null,
  presets: [SwaggerUIBundle.presets.apis],
});
