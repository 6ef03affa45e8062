//! Binary WebSocket frames (placeholder; the codec lands with its golden vectors).
