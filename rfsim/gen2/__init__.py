"""EPC Gen2 (ISO/IEC 18000-63) physical-layer and framing primitives."""
