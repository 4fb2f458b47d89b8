// The OpenAPI page: Swagger UI from the app's own files (no CDN), reading /openapi.json.
'use strict';
window.addEventListener('load', function () {
  const node = document.getElementById('swagger-ui');
  window.ui = SwaggerUIBundle({url: node.dataset.openapiUrl, dom_id: '#swagger-ui',
    deepLinking: true, presets: [SwaggerUIBundle.presets.apis]});
});
