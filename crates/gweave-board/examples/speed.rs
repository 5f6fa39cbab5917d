fn main() {
    let elf = std::env::args().nth(1).unwrap();
    let mut b = gweave_board::Board::new(elf.as_ref(), gweave_board::Wiring::default()).unwrap();
    let t = std::time::Instant::now();
    b.run_for(1.0).unwrap();
    eprintln!("idle: 1 s board in {:?}", t.elapsed());
    b.send_line("M104 S200");
    let t = std::time::Instant::now();
    b.run_for(1.0).unwrap();
    eprintln!("heating: 1 s board in {:?}", t.elapsed());
}
