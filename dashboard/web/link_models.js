// The link models a server describes in its channel catalogue (the link status schema's `model`
// property, x-netkf-models: docs/dashboard.md, "Link models"): both pages read them from here.
// The models in the server's order, each {name, label, keys, example}; null when the schema
// has none.
export function linkModelsOf(schemaText) {
  let models;
  try {
    models = JSON.parse(schemaText).properties.model['x-netkf-models'];
  } catch (err) {
    return null;
  }
  if (!Array.isArray(models)) return null;
  const out = [];
  for (const m of models) {
    if (!m || typeof m.name !== 'string' || !Array.isArray(m.keys)) continue;
    out.push({ name: m.name, label: typeof m.label === 'string' ? m.label : m.name, keys: m.keys.map(String),
      example: m.example || {} });
  }
  return out;
}
