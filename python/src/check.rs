//! Diagnostics as Python objects, and the exception that carries them.

use latticesim_compiler::Checked;
use pyo3::prelude::*;
use pyo3::types::PyList;

pyo3::create_exception!(
    latticesim,
    CheckError,
    pyo3::exceptions::PyValueError,
    "The rules or agents have errors. `str(e)` renders them as `latticesim check` does;\n`e.diagnostics` is the list of every `Diagnostic` (errors and warnings)."
);

pyo3::create_exception!(
    latticesim,
    CheckWarning,
    pyo3::exceptions::PyUserWarning,
    "Warnings of the checker about rules or agents that were loaded all the same."
);

/// One problem found in the rules or agents file, as `latticesim check --format json`
/// gives it: a code (`E201`, `W603`...), the severity, the message, where it is (file,
/// line, column, end), every label (the first is the primary one), a help line and the
/// suggested fixes.
#[pyclass(module = "latticesim", frozen, get_all)]
pub struct Diagnostic {
    /// The code, e.g. `E201`.
    code: String,
    /// `error` or `warning`.
    severity: String,
    /// What is wrong.
    message: String,
    /// The file of the primary label.
    file: String,
    /// Its start line (from 1).
    line: usize,
    /// Its start column (from 1).
    column: usize,
    /// Its end line.
    end_line: usize,
    /// Its end column.
    end_column: usize,
    /// How to fix it, when known.
    help: Option<String>,
    /// Every label as a dict (primary, file, line, column, end_line, end_column, message).
    labels: Py<PyList>,
    /// Suggested fixes as dicts: `message` and `edits` (each file, line, column, end_line,
    /// end_column, start_byte, end_byte and `replacement`), as `check --format json`.
    fixes: Py<PyList>,
}

#[pymethods]
impl Diagnostic {
    fn __repr__(&self) -> String {
        format!(
            "Diagnostic({}[{}] {}:{}:{}: {})",
            self.severity, self.code, self.file, self.line, self.column, self.message
        )
    }

    fn __str__(&self) -> String {
        format!(
            "{}:{}:{}: {}[{}]: {}",
            self.file, self.line, self.column, self.severity, self.code, self.message
        )
    }
}

/// The diagnostics of a check as Python objects.
pub(crate) fn diagnostics<'py>(py: Python<'py>, c: &Checked) -> PyResult<Bound<'py, PyList>> {
    let json = py.import("json")?;
    let out = PyList::empty(py);
    for d in latticesim_compiler::diagnostics::to_json(&c.diags, &c.sources) {
        let as_list = |v: String| -> PyResult<Bound<'py, PyList>> {
            Ok(json.call_method1("loads", (v,))?.cast_into::<PyList>()?)
        };
        let labels = as_list(serde_json::to_string(&d.labels).expect("plain data"))?;
        let fixes = as_list(serde_json::to_string(&d.fixes).expect("plain data"))?;
        out.append(Diagnostic {
            code: d.code.to_string(),
            severity: d.severity.to_string(),
            message: d.message,
            file: d.file,
            line: d.line,
            column: d.column,
            end_line: d.end_line,
            end_column: d.end_column,
            help: d.help,
            labels: labels.unbind(),
            fixes: fixes.unbind(),
        })?;
    }
    Ok(out)
}

/// The exception for a check with errors (or a file the checker could not take whole,
/// `note`): rendered as `latticesim check` renders it, with every diagnostic.
pub(crate) fn error(py: Python<'_>, c: &Checked, note: Option<&str>) -> PyErr {
    let mut text = c.render(false);
    if let Some(n) = note {
        text += n;
        text.push('\n');
    }
    let e = CheckError::new_err(text.trim_end().to_string());
    match diagnostics(py, c) {
        Ok(list) => match e.value(py).setattr("diagnostics", list) {
            Ok(()) => e,
            Err(set) => set,
        },
        Err(d) => d,
    }
}

/// Warns (`CheckWarning`) of the warnings of a check that had no errors.
pub(crate) fn warn(py: Python<'_>, c: &Checked) -> PyResult<()> {
    if c.warnings() == 0 {
        return Ok(());
    }
    let text = c.render(false);
    let category = py.get_type::<CheckWarning>();
    PyErr::warn(
        py,
        &category,
        &std::ffi::CString::new(text.trim_end().replace('\0', " "))?,
        2,
    )
}
