// Shared by the pages: polling the JSON API with the ETag (304 while nothing changed).
// Every text from the server is put in the page with textContent (never as HTML).
'use strict';

function pageData() {
  return JSON.parse(document.getElementById('page-data').textContent);
}

function setText(node, text) {
  if (node && node.textContent !== text) { node.textContent = text; }
}

// Set a text whose dates and times each go in a <span class="t"> (kept on one line by the
// style sheet); the text itself is unchanged.  The pattern of views.TIME_TOKEN.
const TIME_TOKEN = /(\d{4}-\d{2}-\d{2}(?:T\d{2}:\d{2}(?::\d{2})?Z?| \d{2}:\d{2} (?:[A-Z]{2,6}|[+-]\d{2,4})\b)?)/;

function setTimes(node, text) {
  if (!node || node.textContent === text) { return; }
  const parts = text.split(TIME_TOKEN);
  const nodes = parts.map((part, index) => {
    if (index % 2 === 0) { return document.createTextNode(part); }
    const span = document.createElement('span');
    span.className = 't';
    span.textContent = part;
    return span;
  });
  node.replaceChildren(...nodes);
}

// A text for Plotly (hover texts, annotations): Plotly reads a few HTML tags in them (<b>,
// <a href>, <span style>), so the server's texts go in with & < > escaped: shown as text.
function plotlyText(text) {
  return String(text).replace(/&/g, '&amp;').replace(/</g, '&lt;').replace(/>/g, '&gt;');
}

function jointUrl(robot, joint) {
  return '/robots/' + encodeURIComponent(robot) + '/joints/' + encodeURIComponent(joint);
}

// Ask url every intervalMs; call onData(json) when the content changed.
function poll(url, intervalMs, onData) {
  let etag = null;
  const status = document.getElementById('live-status');
  async function once() {
    try {
      const headers = etag ? {'If-None-Match': etag} : {};
      const response = await fetch(url, {headers: headers, cache: 'no-store',
        credentials: 'same-origin'});
      if (response.status === 401) { window.location.assign('/login'); return; }
      if (response.status === 200) {
        etag = response.headers.get('ETag');
        onData(await response.json());
      }
      if (status) { status.className = 'live'; setText(status, 'live'); }
    } catch (error) {
      if (status) { status.className = 'live offline'; setText(status, 'server unreachable'); }
    }
    window.setTimeout(once, intervalMs);
  }
  window.setTimeout(once, intervalMs);
}
