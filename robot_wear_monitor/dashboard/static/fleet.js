// The fleet page: new experiments and states appear in place (rows updated, moved, added).
'use strict';

const CELLS = ['robot', 'joint', 'state', 'wear', 'trend', 'crossing', 'alarm', 'last',
  'experiments'];

function stateClass(state) { return 'state-' + state.replace(/ /g, '-'); }

function newRow() {
  const tr = document.createElement('tr');
  for (const name of CELLS) {
    const td = document.createElement('td');
    td.className = 'c-' + name;
    tr.appendChild(td);
  }
  tr.querySelector('.c-joint').appendChild(document.createElement('a'));
  const badge = document.createElement('span');
  badge.className = 'badge';
  tr.querySelector('.c-state').appendChild(badge);
  const wear = tr.querySelector('.c-wear');
  const svg = document.createElementNS('http://www.w3.org/2000/svg', 'svg');
  svg.setAttribute('class', 'bar');
  svg.setAttribute('viewBox', '0 0 100 14');
  svg.setAttribute('preserveAspectRatio', 'none');
  const parts = [['rect', 'track', {x: 0, y: 4, width: 100, height: 6}],
    ['rect', 'interval', {y: 3, height: 8}], ['line', 'estimate', {y1: 1, y2: 13}],
    ['line', 'threshold', {y1: 0, y2: 14}], ['polygon', 'clip', {points: '94,1 100,7 94,13'}]];
  for (const [tag, cls, attrs] of parts) {
    const node = document.createElementNS('http://www.w3.org/2000/svg', tag);
    node.setAttribute('class', cls);
    for (const key in attrs) { node.setAttribute(key, attrs[key]); }
    svg.appendChild(node);
  }
  wear.appendChild(svg);  // first: the threshold tick at the same x in every row
  const num = document.createElement('span');
  num.className = 'num';
  wear.appendChild(num);
  wear.appendChild(document.createTextNode(' '));
  const thr = document.createElement('span');
  thr.className = 'thr';  // the threshold the row was judged by ('35 (assumed)': not stored)
  wear.appendChild(thr);
  return tr;
}

function setAttr(node, name, value) {
  const text = String(value);
  if (node.getAttribute(name) !== text) { node.setAttribute(name, text); }
}

function updateRow(tr, row) {
  tr.dataset.robot = row.robot;
  tr.dataset.joint = row.joint;
  setAttr(tr, 'class', stateClass(row.state) + (row.stale ? ' stale' : ''));
  setText(tr.querySelector('.c-robot'), row.robot);
  const link = tr.querySelector('.c-joint a');
  setAttr(link, 'href', jointUrl(row.robot, row.joint));
  setText(link, row.joint);
  setText(tr.querySelector('.c-state .badge'), row.state);
  setText(tr.querySelector('.c-wear .num'), row.text.wear);
  setText(tr.querySelector('.c-wear .thr'), 'threshold ' + row.text.threshold);
  const bar = row.bar;
  const interval = tr.querySelector('.interval');
  setAttr(interval, 'x', Math.max(bar.low, 0));
  setAttr(interval, 'width', bar.low >= 0 ? Math.max(bar.high - bar.low, 0) : 0);
  const estimate = tr.querySelector('.estimate');
  setAttr(estimate, 'x1', bar.wear);
  setAttr(estimate, 'x2', bar.wear);
  setAttr(estimate, 'visibility', bar.wear < 0 ? 'hidden' : 'visible');
  const threshold = tr.querySelector('.threshold');
  setAttr(threshold, 'x1', bar.threshold);
  setAttr(threshold, 'x2', bar.threshold);
  setAttr(tr.querySelector('.clip'), 'visibility', bar.clipped ? 'visible' : 'hidden');
  setText(tr.querySelector('.c-trend'), row.text.trend);
  setTimes(tr.querySelector('.c-crossing'), row.text.crossing);
  setTimes(tr.querySelector('.c-alarm'), row.text.alarm);
  setTimes(tr.querySelector('.c-last'), row.text.last);
  setText(tr.querySelector('.c-experiments'), String(row.experiments));
}

function showFleet(fleet) {
  for (const node of document.querySelectorAll('#counts .count')) {
    setText(node, String(fleet.counts[node.dataset.state]));
  }
  setText(document.getElementById('fleet-summary'), fleet.robot_count + ' robots, ' +
    fleet.joints + ' joints, worst first');
  const body = document.getElementById('fleet-rows');
  const old = new Map();
  for (const tr of body.querySelectorAll('tr')) {
    old.set(tr.dataset.robot + '\u0000' + tr.dataset.joint, tr);
  }
  let index = 0;
  for (const row of fleet.rows) {
    const key = row.robot + '\u0000' + row.joint;
    let tr = old.get(key);
    if (tr) { old.delete(key); } else { tr = newRow(); }
    updateRow(tr, row);
    if (body.children[index] !== tr) { body.insertBefore(tr, body.children[index] || null); }
    index += 1;
  }
  for (const tr of old.values()) { tr.remove(); }
  const shown = fleet.total ? 'rows ' + fleet.first.toLocaleString('en') + '\u2013' +
    (fleet.first + fleet.rows.length - 1).toLocaleString('en') + ' of ' +
    fleet.total.toLocaleString('en') : 'no rows';
  for (const node of document.querySelectorAll('.pager [data-role=shown]')) {
    setText(node, shown);
  }
  const none = document.getElementById('no-rows');
  if (none) { none.hidden = fleet.rows.length > 0; }
}

(function () {
  const config = pageData();
  const query = new URLSearchParams();
  if (config.robot) { query.set('robot', config.robot); }
  if (config.state) { query.set('state', config.state); }
  if (config.limit) {  // the same page as the server's (the API pages only when asked)
    query.set('page', String(config.page));
    query.set('limit', String(config.limit));
  }
  const url = config.api + (query.toString() ? '?' + query.toString() : '');
  poll(url, config.poll_ms, showFleet);
})();

// the robot filter is a search: the server suggests at most a few robots whose name holds
// the text typed (GET /api/robots?search=), never the list of every robot
(function () {
  const input = document.getElementById('robot-filter');
  const choices = document.getElementById('robot-choices');
  if (!input || !choices) { return; }
  let asked = '';
  let timer = null;
  function suggest() {
    const text = input.value.trim();
    if (text === asked) { return; }
    asked = text;
    fetch('/api/robots?' + new URLSearchParams({search: text}).toString(),
      {credentials: 'same-origin', headers: {'Accept': 'application/json'}})
      .then(function (response) { return response.ok ? response.json() : null; })
      .then(function (found) {
        if (!found || asked !== text) { return; }
        choices.replaceChildren();
        for (const name of found.robots) {
          const option = document.createElement('option');
          option.value = name;
          choices.appendChild(option);
        }
      })
      .catch(function () { /* no suggestions: the filter still takes the text */ });
  }
  input.addEventListener('input', function () {
    clearTimeout(timer);
    timer = setTimeout(suggest, 200);
  });
  input.addEventListener('focus', suggest);
})();
