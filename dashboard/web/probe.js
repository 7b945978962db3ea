// What a test (tests/e2e/dashboard_browser.mjs) reads as window.netkfDashboard; the modules
// update it as messages arrive and as they draw.
export const dash = {
  estimatesReceived: 0,
  truthReceived: 0,
  lastK: null,
  messagesReceived: 0,
  decodeErrors: 0,
  eventCount: 0,
  pointsPlotted: 0,          // estimate points in the first state chart
  revisionsReceived: 0,      // revised estimates (revision > 0, late_policy fuse_within)
  finalPointsPlotted: 0,     // periods in the plotted window whose final estimate is a revision
  finalSeries: false,        // the charts carry the final-estimate series and band
  finalVerdict: null,        // the final estimates' "stable" ("yes"/"no"/"unknown"), null without one
  recentRevisions: [],       // the last revised estimates taken: {k, revision, x_hat}
  theoryBands: null,         // the latest theory's bands: {configured, final: {stable, lower, upper} or null}
  plotLengths: {},           // uPlot data lengths per chart, after the last redraw
  setParametersSent: 0,
  linkTableMs: null,         // the last link table redraw (filter, sort, rows), ms
  connected: false,
};
window.netkfDashboard = dash;
