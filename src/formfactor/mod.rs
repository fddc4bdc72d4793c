//! Form factors: exact analytic references (point and patch to polygon).

pub mod analytic;
