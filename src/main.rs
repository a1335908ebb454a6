fn main() {
    println!("preston {}", env!("CARGO_PKG_VERSION"));
}
