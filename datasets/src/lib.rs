//! Loop data readers and the closed-loop benchmark simulator.
