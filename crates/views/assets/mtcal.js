// mtcal dashboard: the only script. Progress of running jobs, and the upload form.
// Elements with data-job="ID" data-poll="URL" are polled once a second; the URL is the
// API's GET /api/v1/jobs/{id} (state, progress, progress_message, error_message,
// result_id), which reads the session cookie as its key. When a job ends, the page
// reloads so that the new check, its verdict and its plots appear.
(function () {
  "use strict";
  var TERMINAL = { succeeded: 1, failed: 1, cancelled: 1 };

  function poll(el) {
    var url = el.getAttribute("data-poll");
    fetch(url, { credentials: "same-origin", headers: { Accept: "application/json" } })
      .then(function (r) { return r.ok ? r.json() : Promise.reject(r.status); })
      .then(function (job) {
        var bar = el.querySelector("progress");
        if (bar) { bar.value = job.progress || 0; }
        var state = el.querySelector("[data-state]");
        if (state) {
          state.textContent = job.state;
          state.setAttribute("data-state", job.state);
          state.className = "badge state " + job.state;
        }
        var msg = el.querySelector(".message");
        if (msg) { msg.textContent = job.error_message || job.progress_message || ""; }
        if (TERMINAL[job.state]) {
          el.setAttribute("data-done", job.state);
          if (el.hasAttribute("data-reload")) { window.location.reload(); }
        } else {
          window.setTimeout(function () { poll(el); }, 1000);
        }
      })
      .catch(function () { window.setTimeout(function () { poll(el); }, 3000); });
  }

  function uploadForm(form) {
    var input = form.querySelector("input[type=file]");
    var list = form.querySelector(".files");
    if (!input || !list) { return; }
    input.addEventListener("change", function () {
      var names = [];
      for (var i = 0; i < input.files.length; i++) { names.push(input.files[i].name); }
      list.textContent = names.length ? names.join(", ") : "";
    });
    form.addEventListener("submit", function () {
      var button = form.querySelector("button[type=submit]");
      if (button) { button.disabled = true; button.textContent = "Uploading…"; }
    });
  }

  // /signin#key=mtk_… (the link `mtcal demo` prints): fill the key in and sign in. The
  // fragment never reaches the server; it is removed from the address bar first.
  function signinFromFragment() {
    var m = /^#key=([A-Za-z0-9_]+)$/.exec(window.location.hash);
    var input = document.getElementById("key");
    if (!m || !input || !input.form) { return; }
    window.history.replaceState(null, "", window.location.pathname + window.location.search);
    input.value = m[1];
    input.form.submit();
  }

  document.addEventListener("DOMContentLoaded", function () {
    signinFromFragment();
    var jobs = document.querySelectorAll("[data-job][data-poll]");
    for (var i = 0; i < jobs.length; i++) {
      var s = jobs[i].querySelector("[data-state]");
      if (!s || !TERMINAL[s.getAttribute("data-state")]) { poll(jobs[i]); }
    }
    var forms = document.querySelectorAll("form.upload");
    for (var j = 0; j < forms.length; j++) { uploadForm(forms[j]); }
  });
})();
