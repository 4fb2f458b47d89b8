// The joint page: w per experiment with 95 % intervals, the trend band, the forecast cone,
// T-hat, the friction levels against the model; redrawn in place (Plotly.react) on news.
'use strict';

const COLORS = ['#1f77b4', '#ff7f0e', '#2ca02c', '#9467bd', '#8c564b'];

function ms(seconds) { return seconds === null ? null : seconds * 1000; }

// w-hat with its interval and the trend of some experiments; the old life before a reset is
// drawn grey (its points stay on the chart, the current life is in colour).
function lifeTraces(ex, old) {
  const x = ex.map((e) => ms(e.stamp_s));
  const tag = old ? ' (before the reset)' : '';
  const wearColor = old ? '#9aa5b1' : '#1f77b4';
  return [
    {x: x, y: ex.map((e) => e.trend_high), name: 'trend 95 % band' + tag, mode: 'lines',
      line: {width: 0}, showlegend: false, hoverinfo: 'skip'},
    {x: x, y: ex.map((e) => e.trend_low), name: 'trend 95 % band' + tag, mode: 'lines',
      fill: 'tonexty', fillcolor: old ? 'rgba(154,165,177,0.15)' : 'rgba(44,160,44,0.18)',
      line: {width: 0}},
    {x: x, y: ex.map((e) => e.trend_wear), name: 'trend' + tag, mode: 'lines',
      line: {color: old ? '#9aa5b1' : '#2ca02c', width: 2}},
    {x: x, y: ex.map((e) => e.wear), name: 'w-hat' + tag, mode: 'markers',
      marker: {color: wearColor, size: 6},
      error_y: {type: 'data', symmetric: false,
        color: old ? 'rgba(154,165,177,0.5)' : 'rgba(31,119,180,0.5)',
        array: ex.map((e) => (e.wear_high === null ? null : e.wear_high - e.wear)),
        arrayminus: ex.map((e) => (e.wear_low === null ? null : e.wear - e.wear_low))},
      text: ex.map((e) => plotlyText(e.time +
        (e.valid ? '' : ' INVALID: ' + e.invalid_reason))),
      hovertemplate: '%{text}<br>w-hat %{y:.1f}' + tag + '<extra></extra>'},
  ];
}

function wearTraces(data) {
  const ex = data.experiments;
  const x = ex.map((e) => ms(e.stamp_s));
  const oldLife = ex.filter((e) => e.current_life === false);
  const traces = [
    ...(oldLife.length ? lifeTraces(oldLife, true) : []),
    ...lifeTraces(ex.filter((e) => e.current_life !== false), false),
  ];
  const failed = ex.filter((e) => e.model_check_failed);
  traces.push({x: failed.map((e) => ms(e.stamp_s)), y: failed.map((e) => e.wear),
    name: 'model check failed (p < ' + data.model_check_p_value + ')', mode: 'markers',
    marker: {symbol: 'x', color: '#d62728', size: 11, line: {width: 2}}});
  let end = x[x.length - 1];
  const cone = data.forecast;
  if (cone) {
    const cx = cone.time_s.map(ms);
    end = cx[cx.length - 1];
    traces.push({x: cx, y: cone.high, mode: 'lines', line: {width: 0}, showlegend: false,
      hoverinfo: 'skip', name: 'forecast cone'});
    traces.push({x: cx, y: cone.low, mode: 'lines', fill: 'tonexty', name: 'forecast cone',
      fillcolor: 'rgba(255,127,14,0.18)', line: {width: 0}});
    traces.push({x: cx, y: cone.wear, mode: 'lines', name: 'forecast',
      line: {color: '#ff7f0e', dash: 'dash'}});
    traces.push({x: [ms(cone.crossing_low_time_s), ms(cone.crossing_high_time_s)],
      y: [data.threshold, data.threshold], mode: 'lines', name: 'crossing 95 %',
      line: {color: '#ff7f0e', width: 6}});
    traces.push({x: [ms(cone.crossing_time_s)], y: [data.threshold], mode: 'markers',
      name: 'crossing ' + cone.crossing.slice(0, 16).replace('T', ' '),
      marker: {symbol: 'diamond', size: 12, color: '#ff7f0e'}});
  }
  traces.push({x: [x[0], end], y: [data.threshold, data.threshold], mode: 'lines',
    name: 'threshold w = ' + data.threshold_text, line: {color: '#d62728', dash: 'dot'}});
  return traces;
}

// The alarm's events and now as vertical lines with a label at the top: raised at its
// experiment, acknowledged and reset at the moment they were done (the alarm log's times).
const MARKERS = {raised: '#d62728', acknowledged: '#f0a202', reset: '#2ca02c', now: '#5b6b7c'};

function markers(data, nowMs) {
  const shapes = [];
  const annotations = [];
  const items = data.events.filter((e) => e.stamp_s !== null && MARKERS[e.event])
    .map((e) => ({x: ms(e.stamp_s), kind: e.event, hover: plotlyText((e.time_text || e.time) + ' ' + e.event +
      (e.user ? ' by ' + e.user : '') + (e.note ? ': ' + e.note : ''))}));
  items.push({x: nowMs, kind: 'now', hover: 'now'});
  items.sort((a, b) => a.x - b.x);
  items.forEach((item, index) => {
    shapes.push({type: 'line', xref: 'x', yref: 'paper', x0: item.x, x1: item.x, y0: 0, y1: 1,
      line: {color: MARKERS[item.kind], width: 1.5, dash: item.kind === 'now' ? 'dot' : 'dash'},
      name: 'marker ' + item.kind});
    annotations.push({x: item.x, xref: 'x', yref: 'paper', y: 1 - 0.07 * (index % 3),
      yanchor: 'top', text: item.kind, hovertext: item.hover, showarrow: false,
      font: {size: 11, color: MARKERS[item.kind]}, bgcolor: 'rgba(255,255,255,0.85)',
      xanchor: item.kind === 'now' ? 'right' : 'left', name: 'marker ' + item.kind});
  });
  return {shapes: shapes, annotations: annotations};
}

// The charts' titles are the page's (h3.chart-title above each chart), never in the plot, so
// the mode bar and the legend cannot cover them.  On a narrow screen (dashboard.css's phone
// layout, up to 760 px) the mode bar is left out (zoom and pan stay: touch), the margins
// shrink and every legend sits below its plot, under the axis title.
const NARROW = '(max-width: 760px)';

function narrow() { return window.matchMedia(NARROW).matches; }

function layout(xtitle, ytitle) {
  const small = narrow();
  return {margin: small ? {l: 44, r: 8, t: 8, b: 8} : {l: 60, r: 20, t: 34, b: 10},
    font: {size: small ? 11 : 12},
    xaxis: {type: 'date', title: {text: xtitle}, automargin: true, nticks: small ? 4 : 0},
    yaxis: {title: {text: ytitle}, automargin: true},
    legend: {orientation: 'h', xref: 'container', x: 0, xanchor: 'left', yref: 'container', y: 0,
      yanchor: 'bottom'},
    uirevision: 'keep', hovermode: 'closest'};
}

function chartConfig() {
  return {displaylogo: false, responsive: true, displayModeBar: narrow() ? false : 'hover'};
}

function temperatureTraces(data) {
  const ex = data.experiments;
  return [{x: ex.map((e) => ms(e.stamp_s)), y: ex.map((e) => e.temperature_degc),
    name: 'T-hat', mode: 'markers', marker: {color: '#9467bd', size: 5},
    error_y: {type: 'data', symmetric: false, color: 'rgba(148,103,189,0.4)',
      array: ex.map((e) => (e.temperature_high_degc === null ? null
        : e.temperature_high_degc - e.temperature_degc)),
      arrayminus: ex.map((e) => (e.temperature_low_degc === null ? null
        : e.temperature_degc - e.temperature_low_degc))}}];
}

function frictionTraces(data) {
  const traces = [];
  data.friction.forEach((f, i) => {
    const color = COLORS[i % COLORS.length];
    traces.push({x: f.speeds_rad_s, y: f.frictions, mode: 'markers', name: f.time.slice(0, 16),
      marker: {color: color, size: 8}, legendgroup: String(i)});
    if (f.model_frictions) {
      traces.push({x: f.model_speeds_rad_s, y: f.model_frictions, mode: 'lines',
        name: 'model at T ' + f.temperature_degc.toFixed(1) + ' degC, w ' + f.wear.toFixed(1),
        line: {color: color, width: 1.5}, legendgroup: String(i), showlegend: false});
    }
  });
  return traces;
}

// The joint log's cells as _events.html draws them: class and label (a card's on a phone).
const EVENT_CELLS = [['c-time', 'time'], ['c-event', 'event'], ['c-w', 'w'], ['c-user', 'user'],
  ['c-owner', 'owner'], ['c-time c-planned', 'planned maintenance'],
  ['c-work-order', 'work order'], ['c-note', 'note']];

function showEvents(events) {
  const body = document.querySelector('#joint-events tbody');
  const rows = events.map((e) => {
    const tr = document.createElement('tr');
    tr.className = 'event-' + e.event;
    tr.dataset.id = String(e.id);
    const cells = [e.time_text || e.time, e.event, e.wear === null ? '-' : e.wear.toFixed(1), e.user,
      e.owner, e.planned_maintenance, e.work_order, e.note_text];
    cells.forEach((text, index) => {
      const td = document.createElement('td');
      td.className = EVENT_CELLS[index][0];
      td.dataset.label = EVENT_CELLS[index][1];
      td.textContent = text;
      tr.appendChild(td);
    });
    return tr;
  });
  const ids = Array.from(body.children).map((tr) => tr.dataset.id).join(',');
  if (ids !== events.map((e) => String(e.id)).join(',')) { body.replaceChildren(...rows); }
}

function showJoint(data) {
  const s = data.state;
  if (s) {
    const state = document.getElementById('f-state');
    setText(state, s.state);
    state.className = 'badge state-' + s.state.replace(/ /g, '-');
    setText(document.getElementById('f-wear'), s.text.wear);
    setText(document.getElementById('f-trend'), s.text.trend);
    setTimes(document.getElementById('f-crossing'), s.text.crossing);
    setTimes(document.getElementById('f-alarm'), s.text.alarm);
    setText(document.getElementById('f-experiments'), String(s.experiments));
    setTimes(document.getElementById('f-last'), s.text.last);
  }
  setText(document.getElementById('f-threshold'), data.threshold_text);
  const threshold = data.threshold;
  const wearLayout = layout('experiment end (UTC)', 'wear w');
  wearLayout.yaxis.range = [0, Math.max(threshold * 1.3,
    ...data.experiments.map((e) => (e.wear_high === null ? e.wear : e.wear_high)))];
  const marks = markers(data, Date.now());
  wearLayout.shapes = marks.shapes;
  wearLayout.annotations = marks.annotations;
  const config = chartConfig();
  Plotly.react('wear-chart', wearTraces(data), wearLayout, config);
  Plotly.react('temperature-chart', temperatureTraces(data),
    layout('experiment end (UTC)', 'T [degC]'), config);
  const friction = layout('motor-side speed [rad/s]', 'friction [normalised]');
  friction.xaxis = {title: {text: 'motor-side speed [rad/s]'}, automargin: true};
  friction.legend.title = {text: 'experiment (UTC)', side: 'top'};
  Plotly.react('friction-chart', frictionTraces(data), friction, config);
  showEvents(data.events);
}

(function () {
  const config = pageData();
  let latest = config.data;
  const show = (data) => { latest = data; showJoint(data); };
  show(latest);
  poll(config.api, config.poll_ms, show);
  // a window turned or resized across the phone layout's edge: the charts drawn for it
  window.matchMedia(NARROW).addEventListener('change', () => showJoint(latest));
})();
