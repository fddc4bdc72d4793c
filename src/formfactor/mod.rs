//! formfactor
