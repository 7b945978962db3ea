// The page's elements: found by id, or made with their attributes and children.

export const $ = (id) => document.getElementById(id);

// attrs: 'text' sets the text, 'class' the class name, any other key an attribute.
export function el(tag, attrs, children) {
  const node = document.createElement(tag);
  for (const [key, value] of Object.entries(attrs || {})) {
    if (key === 'text') node.textContent = value;
    else if (key === 'class') node.className = value;
    else node.setAttribute(key, value);
  }
  for (const child of children || []) node.appendChild(child);
  return node;
}
