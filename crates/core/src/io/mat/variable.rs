//! What a `.mat` file holds as the readers see it: its variables ([`Variable`], with MATLAB's
//! class names) and the readers' errors ([`MatError`], each naming the file).

use std::path::PathBuf;

/// Problems reading a `.mat` file; every variant names the file.
#[derive(Debug, thiserror::Error)]
pub enum MatError {
    /// The file cannot be opened or read.
    #[error("cannot read {path}: {cause}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause (in the message, not a `source()`, so that a chain printed with `{:#}`
        /// says it once).
        cause: std::io::Error,
    },
    /// The file is not a MAT file this build reads, or its bytes are malformed.
    #[error("{path}: {reason}")]
    Format {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// The requested variable is not in the file.
    #[error("{path} has no variable {name:?}; it holds: {}", list(.variables))]
    Missing {
        /// The file.
        path: PathBuf,
        /// The requested name.
        name: String,
        /// What the file holds.
        variables: Vec<Variable>,
    },
    /// No variable was named and the file does not hold exactly one numeric 3-D array.
    #[error("{path} holds {count} numeric 3-D arrays, so name the variable to read; it holds: {}", list(.variables))]
    Ambiguous {
        /// The file.
        path: PathBuf,
        /// How many numeric 3-D arrays the file holds.
        count: usize,
        /// What the file holds.
        variables: Vec<Variable>,
    },
    /// The variable exists but is not a numeric 3-D array.
    #[error("{path}: variable {name:?} is {what}; a stack is a numeric 3-D array (H x W x N)")]
    NotStack {
        /// The file.
        path: PathBuf,
        /// The variable.
        name: String,
        /// What it is instead.
        what: String,
    },
    /// A stack does not fit in memory.
    #[error(transparent)]
    Alloc(#[from] crate::alloc::AllocError),
}

fn list(v: &[Variable]) -> String {
    if v.is_empty() {
        return "no variables".into();
    }
    v.iter()
        .map(|v| format!("{} ({})", v.name, v.describe()))
        .collect::<Vec<_>>()
        .join(", ")
}

/// A top-level variable of a MAT file, as listed without reading its data.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Variable {
    /// Its name.
    pub name: String,
    /// MATLAB's class name (`double`, `single`, `int16`, `struct`, `cell`, `char`, `sparse`,
    /// `object`, ...).
    pub class: &'static str,
    /// Its dimensions (MATLAB order); empty where the file does not say without reading more
    /// (a v7.3 struct, an object).
    pub dims: Vec<usize>,
    /// Whether it is complex.
    pub complex: bool,
    /// Whether it is a logical array.
    pub logical: bool,
    /// What the data are stored as where that is not numbers although the class is numeric
    /// (a v7.3 dataset of strings, booleans or an unknown compound whose `MATLAB_class` says
    /// `double`); `None` where the storage agrees with the class.
    pub stored_as: Option<String>,
}

impl Variable {
    /// Whether it is a numeric (not logical) array.
    pub fn is_numeric(&self) -> bool {
        numeric_class(self.class) && !self.logical && self.stored_as.is_none()
    }

    /// Whether it can be read as a stack.
    pub fn is_stack(&self) -> bool {
        self.is_numeric() && self.dims.len() == 3
    }

    /// `4x5x3 single complex` (the dimensions left out where unknown; `... stored as bool`
    /// where the data are not numbers).
    pub fn describe(&self) -> String {
        let dims: Vec<String> = self.dims.iter().map(usize::to_string).collect();
        let kind = if self.logical { "logical" } else { self.class };
        let cx = if self.complex { " complex" } else { "" };
        let stored = match &self.stored_as {
            Some(s) => format!(" stored as {s}"),
            None => String::new(),
        };
        if dims.is_empty() {
            format!("{kind}{cx}{stored}")
        } else {
            format!("{} {kind}{cx}{stored}", dims.join("x"))
        }
    }

    /// What the variable is, in words, where it is not a stack (`None` for a stack).
    pub fn not_stack_reason(&self) -> Option<String> {
        if self.is_stack() {
            return None;
        }
        Some(match self.class {
            "struct" => "a struct".to_string(),
            "cell" => "a cell array".to_string(),
            "char" => "a char array".to_string(),
            "sparse" => "a sparse matrix".to_string(),
            "object" | "opaque" | "function_handle" => format!("a MATLAB {} object", self.class),
            _ if self.stored_as.is_some() => format!(
                "stored as {}, not as numbers (its MATLAB_class says {})",
                self.stored_as.as_deref().unwrap_or_default(),
                if self.logical { "logical" } else { self.class }
            ),
            _ if self.logical => "a logical array".to_string(),
            _ if self.is_numeric() => format!("{}-D ({})", self.dims.len(), self.describe()),
            _ => format!("of class {}", self.class),
        })
    }
}

/// MATLAB's class names in the order of MAT v5's class codes (`mxCELL_CLASS` = 1, ...).
pub(super) const CLASSES: [&str; 18] = [
    "unknown",
    "cell",
    "struct",
    "object",
    "char",
    "sparse",
    "double",
    "single",
    "int8",
    "uint8",
    "int16",
    "uint16",
    "int32",
    "uint32",
    "int64",
    "uint64",
    "function_handle",
    "opaque",
];

/// Whether `c` is one of the numeric classes (`double` to `uint64`).
pub(super) fn numeric_class(c: &str) -> bool {
    CLASSES[6..16].contains(&c)
}
