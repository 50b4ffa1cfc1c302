// ---------------------------------------------------------------- planar targets

fn chess_value(x: f32, y: f32) -> f32 {
    let s = P.board.z; let m = P.board.w;
    let w = P.board.x * s; let h = P.board.y * s;
    if (x >= 0.0 && x < w && y >= 0.0 && y < h) {
        let ij = i32(floor(x / s)) + i32(floor(y / s));
        return select(P.grey.y, P.grey.x, (ij & 1) == 0);
    }
    if (x >= -m && x < w + m && y >= -m && y < h + m) { return P.grey.z; }
    return P.grey.w;
}

fn grid_value(x: f32, y: f32) -> f32 {
    let n = P.board.x; let hh = 0.5 * P.board.y; let rad = P.board.z; let outer = hh + P.board.w;
    if (x < -outer || x >= outer || y < -outer || y >= outer) { return P.grey.w; }
    let pitch = P.board.y / (n - 1.0);
    let ix = clamp(round((x + hh) / pitch), 0.0, n - 1.0);
    let iy = clamp(round((y + hh) / pitch), 0.0, n - 1.0);
    let d = vec2<f32>(x + hh - pitch * ix, y + hh - pitch * iy);
    return select(P.grey.y, P.grey.x, dot2(d, d) < rad * rad);
}

fn plane_value(b: vec2<f32>) -> f32 {
    if (P.size.z == KIND_CODED) { return coded_value(b.x, b.y); }
    return select(grid_value(b.x, b.y), chess_value(b.x, b.y), P.size.z == KIND_CHESSBOARD);
}

