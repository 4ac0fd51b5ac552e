//! Figures and the HTML report of liftwatch (in progress).
