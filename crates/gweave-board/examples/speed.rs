fn main() {
    let elf = std::env::args().nth(1).unwrap();
    let mut b = gweave_board::Board::new(elf.as_ref(), gweave_board::Wiring::default()).unwrap();
    b.run_for(0.5).unwrap();
    b.send_line("M109 S210");
    let mut last = 0.0;
    while b.now_s() < 140.0 {
        b.run_for(0.5).unwrap();
        for l in b.lines() {
            eprintln!("{:.1} {l}", b.now_s());
        }
        if b.now_s() - last >= 2.0 {
            last = b.now_s();
            eprintln!(
                "{:.1} {:.2} {:.1}",
                b.now_s(),
                b.plant(0).heater.sensor_c(),
                b.plant(0).heater.last_power_w()
            );
        }
    }
}
