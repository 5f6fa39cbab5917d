/*
 * The C side of the emulated RAMPS board: the few libsimavr calls that need its structs or
 * its callbacks, behind a small API the Rust side (src/sim.rs) calls. Everything the board
 * *means* (axes, endstops, heaters) lives in Rust; this file only wires simavr.
 *
 * simavr's API: sim_avr.h, sim_io.h, sim_irq.h, avr_uart.h, avr_ioport.h, avr_adc.h
 * (https://github.com/buserror/simavr, simavr/sim/).
 */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include <simavr/sim_avr.h>
#include <simavr/sim_elf.h>
#include <simavr/sim_io.h>
#include <simavr/sim_irq.h>
#include <simavr/sim_time.h>
#include <simavr/sim_interrupts.h>
#include <simavr/avr_uart.h>
#include <simavr/avr_ioport.h>
#include <simavr/avr_adc.h>
#include <simavr/avr_extint.h>

/* What a callback reports to Rust. */
enum { GW_UART_OUT = 0, GW_PIN = 1 };

typedef void (*gw_event_fn)(void *user, uint32_t kind, uint32_t index, uint32_t value, uint64_t cycle);

/* One watched pin: which board and which index to report. */
typedef struct gw_pin {
	struct gw_board *board;
	uint32_t index;
} gw_pin;

#define GW_MAX_PINS 32
#define GW_ADC_CHANNELS 16
#define GW_PORTS 12
/* The ATmega2560's 256 KB of flash, in 16-bit words. */
#define GW_PROFILE_WORDS (128 * 1024)
#define GW_PROFILE_DEPTH 64

typedef struct gw_board {
	avr_t *avr;
	gw_event_fn event;
	void *user;
	/* simavr's receive FIFO is full (UART_IRQ_OUT_XOFF): hold the next byte back. */
	int rx_full;
	/* Millivolts on each analog input; see adc_trigger. */
	uint32_t adc_mv[GW_ADC_CHANNELS];
	gw_pin pins[GW_MAX_PINS];
	uint32_t pin_count;
	/* Lowest stack pointer seen (the stack grows down from RAMEND). */
	uint16_t min_sp;
	avr_uart_t *uart0;
	/* When the firmware last wrote a byte to send. */
	avr_cycle_count_t last_tx_cycle;
	/* The interrupt handler being timed (its vector's flash address), when it started, and the
	 * longest it took, in cycles (from the vector to the `reti` that sets I again). */
	avr_flashaddr_t timed_vector;
	avr_cycle_count_t isr_start;
	int in_isr;
	avr_cycle_count_t isr_max_cycles;
	avr_cycle_count_t isr_total_cycles;
	uint64_t isr_count;
	/* Levels driven from outside, per port (A..L). */
	avr_ioport_external_t external[GW_PORTS];
	/* The program counter's profile, while on: the cycles spent at each flash word (`self`)
	 * and in each function with what it calls (`inclusive`, by the function's first word).
	 * The calls are followed on a shadow stack: a frame starts when the program counter
	 * reaches a function's first word (`entry`, a bit per word), with the stack pointer then
	 * (the return address pushed), and ends when the stack pointer rises above it (`ret`). */
	uint32_t *profile;
	uint32_t *inclusive;
	uint8_t *entry;
	struct { avr_flashaddr_t word; uint16_t sp; } frames[GW_PROFILE_DEPTH];
	int depth;
} gw_board;

static void profile_free(gw_board *b);

static void uart_out(struct avr_irq_t *irq, uint32_t value, void *param)
{
	gw_board *b = param;
	b->last_tx_cycle = b->avr->cycle;
	b->event(b->user, GW_UART_OUT, 0, value & 0xFF, b->avr->cycle);
}

static void uart_xon(struct avr_irq_t *irq, uint32_t value, void *param)
{
	((gw_board *)param)->rx_full = 0;
}

static void uart_xoff(struct avr_irq_t *irq, uint32_t value, void *param)
{
	((gw_board *)param)->rx_full = value != 0;
}

static void pin_changed(struct avr_irq_t *irq, uint32_t value, void *param)
{
	gw_pin *p = param;
	p->board->event(p->board->user, GW_PIN, p->index, value, p->board->avr->cycle);
}

/*
 * simavr 1.6 keeps the voltage of ADC0-7 only (adc_values[8]) yet reads adc_values[src] for
 * any channel, so ADC8-15 read past the array. The ATmega2560's mux table is patched to read
 * slot `channel & 7` for those channels, and when a conversion starts (ADC_IRQ_OUT_TRIGGER)
 * the slot is loaded with the voltage of the channel the firmware selected, read from ADMUX
 * (MUX4:0) and ADCSRB (MUX5). Nothing on RAMPS reads ADC0-7, so sharing the slots is safe.
 */
#define ADMUX_ADDR 0x7C
#define ADCSRB_ADDR 0x7B

static void adc_trigger(struct avr_irq_t *irq, uint32_t value, void *param)
{
	gw_board *b = param;
	uint8_t channel = (b->avr->data[ADMUX_ADDR] & 0x07) | ((b->avr->data[ADCSRB_ADDR] & 0x08) ? 8 : 0);
	avr_raise_irq(avr_io_getirq(b->avr, AVR_IOCTL_ADC_GETIRQ, ADC_IRQ_ADC0 + (channel & 7)),
		      b->adc_mv[channel]);
}

static avr_io_t *find_io(avr_t *avr, const char *kind, int nth)
{
	for (avr_io_t *io = avr->io_port; io; io = io->next)
		if (strcmp(io->kind, kind) == 0 && nth-- == 0)
			return io;
	return NULL;
}

static void patch_adc_mux(avr_t *avr)
{
	avr_adc_t *adc = (avr_adc_t *)find_io(avr, "adc", 0);
	if (!adc)
		return;
	for (unsigned i = 0; i < sizeof(adc->muxmode) / sizeof(adc->muxmode[0]); i++)
		if (adc->muxmode[i].kind == ADC_MUX_SINGLE && adc->muxmode[i].src >= 8)
			adc->muxmode[i].src &= 7;
}

/* An ATmega2560 at `hz` running the ELF at `path`; NULL if it cannot be loaded. */
gw_board *gw_board_new(const char *path, uint32_t hz, gw_event_fn event, void *user)
{
	elf_firmware_t *fw = calloc(1, sizeof(*fw));
	gw_board *b = calloc(1, sizeof(*b));
	if (!fw || !b || elf_read_firmware(path, fw) != 0)
		goto fail;
	b->avr = avr_make_mcu_by_name("atmega2560");
	if (!b->avr)
		goto fail;
	avr_init(b->avr);
	avr_load_firmware(b->avr, fw);
	free(fw);
	fw = NULL;
	b->avr->frequency = hz;
	/* RAMPS runs the Mega at 5 V; the ADC's reference is AVCC. */
	b->avr->vcc = b->avr->avcc = b->avr->aref = 5000;
	b->avr->log = LOG_ERROR;
	b->event = event;
	b->user = user;
	b->min_sp = 0xFFFF;

	/* No console echo of the serial port and no real-time sleeps while the firmware polls. */
	uint32_t flags = 0;
	avr_ioctl(b->avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
	avr_irq_register_notify(avr_io_getirq(b->avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT), uart_out, b);
	avr_irq_register_notify(avr_io_getirq(b->avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XON), uart_xon, b);
	avr_irq_register_notify(avr_io_getirq(b->avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XOFF), uart_xoff, b);
	b->uart0 = (avr_uart_t *)find_io(b->avr, "uart", 0);

	/*
	 * simavr 1.6 polls a low external-interrupt pin every cycle while its sense control is
	 * "low level" (the reset value), even with the interrupt disabled: the X and Z endstops
	 * (INT5, INT3) are low while open, which made the emulator three times slower. The
	 * firmware reads the endstops by polling, so the level polling is switched off.
	 */
	for (int i = 0; i < EXTINT_COUNT; i++)
		avr_extint_set_strict_lvl_trig(b->avr, i, 0);

	patch_adc_mux(b->avr);
	avr_irq_register_notify(avr_io_getirq(b->avr, AVR_IOCTL_ADC_GETIRQ, ADC_IRQ_OUT_TRIGGER), adc_trigger, b);
	return b;
fail:
	free(fw);
	free(b);
	return NULL;
}

void gw_board_free(gw_board *b)
{
	if (!b)
		return;
	avr_terminate(b->avr);
	profile_free(b);
	free(b);
}

/* Report every change of pin `bit` of `port` ('A'..'L') as a GW_PIN event with `index`. */
int gw_board_watch_pin(gw_board *b, char port, int bit, uint32_t index)
{
	avr_irq_t *irq = avr_io_getirq(b->avr, AVR_IOCTL_IOPORT_GETIRQ(port), bit);
	if (!irq || b->pin_count == GW_MAX_PINS)
		return -1;
	gw_pin *p = &b->pins[b->pin_count++];
	p->board = b;
	p->index = index;
	avr_irq_register_notify(irq, pin_changed, p);
	return 0;
}

/*
 * Drive an input pin from outside (an endstop switch). simavr raises an input pin to 1 on
 * every write to its PORT register when its pull-up is on, which would undo the drive; the
 * port's "external" level (AVR_IOCTL_IOPORT_SET_EXTERNAL) takes precedence over the pull-up.
 */
void gw_board_drive_pin(gw_board *b, char port, int bit, int level)
{
	int i = port - 'A';
	if (i < 0 || i >= GW_PORTS)
		return;
	b->external[i].name = port;
	b->external[i].mask |= 1u << bit;
	if (level)
		b->external[i].value |= 1u << bit;
	else
		b->external[i].value &= ~(1u << bit);
	avr_ioctl(b->avr, AVR_IOCTL_IOPORT_SET_EXTERNAL(port), &b->external[i]);
	avr_raise_irq(avr_io_getirq(b->avr, AVR_IOCTL_IOPORT_GETIRQ(port), bit), level ? 1 : 0);
}

void gw_board_set_adc_mv(gw_board *b, uint32_t channel, uint32_t mv)
{
	if (channel < GW_ADC_CHANNELS)
		b->adc_mv[channel] = mv;
}

/* Whether simavr's receive FIFO has room for another byte. */
int gw_board_rx_ready(gw_board *b)
{
	return !b->rx_full;
}

void gw_board_uart_push(gw_board *b, uint8_t byte)
{
	avr_raise_irq(avr_io_getirq(b->avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT), byte);
}

/*
 * simavr 1.6 counts a parity bit in every byte (11 bits for 8N1, which sends 10), so serial
 * runs 10 % slow. The byte time is set again from UBRR0 and U2X0, ten bits a byte.
 */
static void uart_fix_byte_time(gw_board *b)
{
	avr_uart_t *u = b->uart0;
	if (!u)
		return;
	uint32_t ubrr = avr_regbit_get(b->avr, u->ubrrl) | (avr_regbit_get(b->avr, u->ubrrh) << 8);
	uint32_t cycles_per_bit = (ubrr + 1) * (avr_regbit_get(b->avr, u->u2x) ? 8 : 16);
	u->cycles_per_byte = cycles_per_bit * 10;
}

/*
 * simavr 1.6 raises UDRE (transmit register free) only from the timer of a byte sent with the
 * transmitter on, and clears it when the transmitter is switched off: a firmware that switches
 * it off and on again (as Arduino's start-up code does) and then polls UDRE waits forever. The
 * harness raises it when the transmitter is on and the last byte left two byte times ago.
 */
static void uart_raise_udre(gw_board *b)
{
	avr_uart_t *u = b->uart0;
	if (!u || avr_regbit_get(b->avr, u->udrc.raised) || !avr_regbit_get(b->avr, u->txen))
		return;
	if (b->avr->cycle - b->last_tx_cycle > 2 * u->cycles_per_byte)
		avr_raise_interrupt(b->avr, &u->udrc);
}

/* Count `cycles` spent at `pc` (before the step), then follow the calls and returns. */
static void profile_step(gw_board *b, avr_flashaddr_t pc, uint32_t cycles)
{
	b->profile[(pc >> 1) & (GW_PROFILE_WORDS - 1)] += cycles;
	for (int i = 0; i < b->depth; i++)
		b->inclusive[b->frames[i].word] += cycles;
	uint16_t sp = b->avr->data[0x5D] | (b->avr->data[0x5E] << 8);
	while (b->depth > 0 && b->frames[b->depth - 1].sp < sp)
		b->depth--;
	avr_flashaddr_t word = (b->avr->pc >> 1) & (GW_PROFILE_WORDS - 1);
	if (word != (pc >> 1) && (b->entry[word >> 3] >> (word & 7) & 1) && b->depth < GW_PROFILE_DEPTH) {
		b->frames[b->depth].word = word;
		b->frames[b->depth].sp = sp;
		b->depth++;
	}
}

/* Run until the cycle counter reaches `until`; 0 when it did, 1 when the firmware stopped
 * (cpu_Done), 2 when it crashed (cpu_Crashed). */
int gw_board_run(gw_board *b, uint64_t until)
{
	avr_t *avr = b->avr;
	int result = 0;
	while (avr->cycle < until) {
		avr_flashaddr_t pc = avr->pc;
		avr_cycle_count_t before = avr->cycle;
		int state = avr_run(avr);
		if (b->profile)
			profile_step(b, pc, (uint32_t)(avr->cycle - before));
		if (state == cpu_Done || state == cpu_Crashed) {
			result = state == cpu_Done ? 1 : 2;
			break;
		}
		if (b->timed_vector) {
			if (avr->pc == b->timed_vector && !b->in_isr) {
				b->in_isr = 1;
				b->isr_start = avr->cycle;
			} else if (b->in_isr && avr->sreg[S_I]) {
				b->in_isr = 0;
				avr_cycle_count_t took = avr->cycle - b->isr_start;
				if (took > b->isr_max_cycles)
					b->isr_max_cycles = took;
				b->isr_total_cycles += took;
				b->isr_count++;
			}
		}
		uint16_t sp = avr->data[0x5D] | (avr->data[0x5E] << 8);
		if (sp < b->min_sp && sp != 0)
			b->min_sp = sp;
	}
	uart_fix_byte_time(b);
	uart_raise_udre(b);
	return result;
}

static void profile_free(gw_board *b)
{
	free(b->profile);
	free(b->inclusive);
	free(b->entry);
	b->profile = b->inclusive = NULL;
	b->entry = NULL;
	b->depth = 0;
}

/* Start the profile from zero, the functions starting at the `count` byte addresses `entries`
 * (from the ELF's symbols); or stop it (`entries` NULL). -1: out of memory. */
int gw_board_profile(gw_board *b, const uint32_t *entries, uint32_t count)
{
	profile_free(b);
	if (!entries)
		return 0;
	b->profile = calloc(GW_PROFILE_WORDS, sizeof(uint32_t));
	b->inclusive = calloc(GW_PROFILE_WORDS, sizeof(uint32_t));
	b->entry = calloc(GW_PROFILE_WORDS / 8, 1);
	if (!b->profile || !b->inclusive || !b->entry) {
		profile_free(b);
		return -1;
	}
	for (uint32_t i = 0; i < count; i++) {
		uint32_t word = (entries[i] >> 1) & (GW_PROFILE_WORDS - 1);
		b->entry[word >> 3] |= 1 << (word & 7);
	}
	return 0;
}

/* The profile's counters, GW_PROFILE_WORDS of them (word address = byte address / 2): the
 * cycles at each word (`inclusive` 0), or in the function starting there with its callees
 * (`inclusive` 1); NULL when off. */
const uint32_t *gw_board_profile_counts(gw_board *b, int inclusive)
{
	return inclusive ? b->inclusive : b->profile;
}

uint64_t gw_board_cycle(gw_board *b)
{
	return b->avr->cycle;
}

uint16_t gw_board_min_sp(gw_board *b)
{
	return b->min_sp;
}

/* A reset as the RESET pin gives (the Arduino's auto-reset when a host opens the port). */
void gw_board_reset(gw_board *b)
{
	avr_reset(b->avr);
	/* The reset switched the level polling back on (see gw_board_new). */
	for (int i = 0; i < EXTINT_COUNT; i++)
		avr_extint_set_strict_lvl_trig(b->avr, i, 0);
}

/* Time the handler of interrupt `vector` (its number in the datasheet's table, e.g. 17 for
 * TIMER1_COMPA); 0 stops. Each vector is a 4-byte jump on the ATmega2560. */
void gw_board_time_vector(gw_board *b, uint32_t vector)
{
	b->timed_vector = vector * 4;
	b->in_isr = 0;
	b->isr_max_cycles = 0;
	b->isr_total_cycles = 0;
	b->isr_count = 0;
}

uint64_t gw_board_isr_max_cycles(gw_board *b)
{
	return b->isr_max_cycles;
}

/* The mean time of the timed handler, cycles (0 before it ran). */
uint64_t gw_board_isr_mean_cycles(gw_board *b)
{
	return b->isr_count ? b->isr_total_cycles / b->isr_count : 0;
}
