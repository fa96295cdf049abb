/*
 * avr_board: the ROSArduinoBridge firmware (an Arduino Nano build) running in simavr.
 *
 *   avr_board FIRMWARE.elf [--link PATH] [--exchange] [--fast] [--watch ADDR:SIZE]...
 *             [--poke ADDR:SIZE=VALUE]... [--time-function ADDR]
 *
 * The ATmega328P runs at 16 MHz, paced to wall-clock time (unless --fast). Its UART is a
 * pseudo-terminal (simavr's uart_pty); once the firmware has started (2 ms of simulated time) the
 * slave's path is printed on stdout ("P <path>") and, with --link, a symlink at PATH points at it
 * (removed on exit).
 *
 * --exchange: lockstep with a motor model on stdin/stdout, one exchange per millisecond of
 * simulated time. This side writes
 *     D <simulated microseconds> <left PWM> <right PWM>
 * (signed -255..255: what the firmware's setMotorSpeed() wrote on the L298 inputs, forward minus
 * backward) and waits for the answer
 *     <left count> <right count>
 * (the motor-shaft encoder counts, cumulative). It then walks each encoder's two pins through
 * quadrature states towards that count, its edges spread evenly over the next millisecond, so
 * that the firmware's pin-change interrupts count them. Without --exchange the motors are not
 * read and the encoders stand still.
 *
 * --watch ADDR:SIZE (data-space address, 1, 2 or 4 bytes; repeatable): each D line also carries
 * the firmware variable there, unsigned little-endian, in the order given, so that the motor side
 * sees the firmware's state per millisecond (its PID frames, its counts) without changing it.
 * --poke ADDR:SIZE=VALUE (repeatable): write VALUE there at the second simulated millisecond,
 * after the C runtime cleared RAM and setup() ran: a board that powered up with its encoder
 * counts elsewhere (the 32-bit wrap without 2^31 edges).
 * --time-function ADDR (a function's byte address in flash, e.g. updatePID's from avr-nm): each D
 * line also carries, after the watched variables, the AVR cycles its last completed call took,
 * from its first instruction to the return to its caller, interrupts included (0 before the
 * first); at exit the calls' count and least, mean and largest cycles go to stderr.
 *
 * SIGUSR1 resets the ATmega (what DTR does through the Nano's auto-reset capacitor): the firmware
 * boots again, its counts and loop at 0; simulated time keeps running. Ends on SIGINT/SIGTERM/
 * SIGHUP, or at end of input with --exchange.
 */
#include <errno.h>
#include <pthread.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "avr_ioport.h"
#include "parts/uart_pty.h"
#include "sim_avr.h"
#include "sim_elf.h"

#define CPU_HZ 16000000UL
#define USAGE                                                                              \
	"usage: avr_board FIRMWARE.elf [--link PATH] [--exchange] [--fast] [--watch ADDR:SIZE]... " \
	"[--poke ADDR:SIZE=VALUE]... [--time-function ADDR]\n"
#define EXCHANGE_CYCLES (CPU_HZ / 1000) /* one exchange per simulated millisecond */

/* ATmega328P data-space addresses of the registers the L298 pins depend on. */
#define REG_PORTB 0x25
#define REG_PORTD 0x2B
#define REG_TCCR0A 0x44
#define REG_OCR0A 0x47
#define REG_OCR0B 0x48
#define REG_TCCR1A 0x80
#define REG_OCR1AL 0x88
#define REG_OCR1BL 0x8A
#define REG_SPL 0x5D
#define REG_SPH 0x5E

/* One L298 input pin: its PORT bit, and the timer output (COM bit, OCR) analogWrite() uses. */
typedef struct {
	uint8_t port_reg, port_bit, tccr_reg, com_bit, ocr_reg;
} pwm_pin_t;

/* The sketch's motor_driver.h, L298_MOTOR_DRIVER: forward 10/9, backward 6/5. */
static const pwm_pin_t LEFT_FORWARD = {REG_PORTB, 2, REG_TCCR1A, 5, REG_OCR1BL};   /* D10 OC1B */
static const pwm_pin_t LEFT_BACKWARD = {REG_PORTD, 6, REG_TCCR0A, 7, REG_OCR0A};   /* D6 OC0A */
static const pwm_pin_t RIGHT_FORWARD = {REG_PORTB, 1, REG_TCCR1A, 7, REG_OCR1AL};  /* D9 OC1A */
static const pwm_pin_t RIGHT_BACKWARD = {REG_PORTD, 5, REG_TCCR0A, 5, REG_OCR0B};  /* D5 OC0B */

/* One motor's encoder: the two pins (encoder_driver.h: PD2/PD3 left, PC4/PC5 right). */
typedef struct {
	char port;
	uint8_t pin_a, pin_b;
	long shown;   /* the count the pins' quadrature state stands for */
	long target;  /* the count the motor model reported */
	avr_cycle_count_t interval;
} encoder_t;

static avr_t *avr;
static uart_pty_t uart;
static encoder_t encoders[2] = {{'D', 2, 3, 0, 0, 0}, {'C', 4, 5, 0, 0, 0}};

/* A firmware variable in data space: --watch reports it, --poke sets it. */
typedef struct {
	unsigned address, size;
	unsigned long value;
} variable_t;

#define MAX_VARIABLES 16
static variable_t watches[MAX_VARIABLES], pokes[MAX_VARIABLES];
static int watch_count, poke_count;
static volatile sig_atomic_t reset_requested;
static avr_cycle_count_t cycles_before_resets; /* simulated time survives a reset */
static FILE *exchange_out; /* the protocol's stdout; stdout itself is stderr (library chatter) */
static int exchange, fast;
static const char *link_path;
static volatile sig_atomic_t stop_requested;
static struct timespec wall_start;
static double most_behind_s; /* the simulation's largest lag behind wall time (a busy host) */

/* --time-function: the function's entry, the return address of the call under way (0: none),
 * and the cycles of the calls so far. */
static avr_flashaddr_t timed_entry, timed_return;
static avr_cycle_count_t timed_start, timed_last, timed_least, timed_most, timed_total;
static unsigned long timed_calls;
static int timing;

/* After every instruction: a call of the timed function starts, or the one under way returns. */
static void time_function(void)
{
	if (timed_return == 0 && avr->pc == timed_entry) {
		/* CALL pushed the return word address, high byte above the stack pointer. */
		unsigned sp = avr->data[REG_SPL] | (avr->data[REG_SPH] << 8);
		timed_return = ((avr->data[sp + 1] << 8) | avr->data[sp + 2]) * 2;
		timed_start = avr->cycle;
	} else if (timed_return != 0 && avr->pc == timed_return) {
		timed_return = 0;
		timed_last = avr->cycle - timed_start;
		if (timed_calls == 0 || timed_last < timed_least)
			timed_least = timed_last;
		if (timed_last > timed_most)
			timed_most = timed_last;
		timed_total += timed_last;
		timed_calls++;
	}
}

/* What analogWrite()/digitalWrite() left on a pin: the OCR while the timer drives it, else the
 * PORT level (analogWrite(pin, 0) and (pin, 255) are digitalWrite()s that disconnect the timer). */
static int pwm_of(const pwm_pin_t *pin)
{
	if (avr->data[pin->tccr_reg] & (1 << pin->com_bit))
		return avr->data[pin->ocr_reg];
	return (avr->data[pin->port_reg] & (1 << pin->port_bit)) ? 255 : 0;
}

/* Put the encoder's pins at the quadrature state of its shown count. The Gray sequence
 * (B,A) = 00, 01, 11, 10 counts up in the firmware's ENC_STATES table. The levels are set both
 * as pin IRQs (the pin-change interrupt) and as the port's external state: simavr re-applies the
 * pull-ups the firmware enabled on every write of the PORT register, overwriting a level set
 * only through the IRQ. */
static void show_encoder(encoder_t *enc)
{
	static const uint8_t gray[4] = {0, 1, 3, 2};
	uint8_t state = gray[enc->shown & 3];
	uint8_t a = state & 1, b = (state >> 1) & 1;
	avr_ioport_external_t ext = {
		.name = enc->port,
		.mask = (1 << enc->pin_a) | (1 << enc->pin_b),
		.value = (a << enc->pin_a) | (b << enc->pin_b),
	};
	avr_ioctl(avr, AVR_IOCTL_IOPORT_SET_EXTERNAL(enc->port), &ext);
	avr_raise_irq(avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ(enc->port), enc->pin_a), a);
	avr_raise_irq(avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ(enc->port), enc->pin_b), b);
}

/* One quadrature edge towards the target; again after `interval` cycles until it is reached. */
static avr_cycle_count_t encoder_edge(avr_t *a, avr_cycle_count_t when, void *param)
{
	(void)a;
	encoder_t *enc = param;
	if (enc->shown == enc->target)
		return 0;
	enc->shown += enc->target > enc->shown ? 1 : -1;
	show_encoder(enc);
	return enc->shown == enc->target ? 0 : when + enc->interval;
}

static unsigned long read_variable(const variable_t *v)
{
	unsigned long value = 0;
	for (unsigned i = 0; i < v->size; i++)
		value |= (unsigned long)avr->data[v->address + i] << (8 * i);
	return value;
}

static void write_variable(const variable_t *v)
{
	for (unsigned i = 0; i < v->size; i++)
		avr->data[v->address + i] = (v->value >> (8 * i)) & 0xff;
}

/* "ADDR:SIZE" or, with `value`, "ADDR:SIZE=VALUE" (numbers in C notation); 0 when malformed. */
static int parse_variable(const char *text, variable_t *v, int with_value)
{
	char *end;
	v->address = strtoul(text, &end, 0);
	if (*end != ':')
		return 0;
	v->size = strtoul(end + 1, &end, 0);
	if (v->size != 1 && v->size != 2 && v->size != 4)
		return 0;
	if (with_value) {
		if (*end != '=')
			return 0;
		v->value = strtoul(end + 1, &end, 0);
	}
	return *end == 0 && v->address >= 0x100 && v->address + v->size <= 0x900;
}

/* Simulated time since start, across resets. */
static avr_cycle_count_t simulated_cycles(void)
{
	return cycles_before_resets + avr->cycle;
}

static int make_link(const char *target);

/* The pty is usable once the firmware has started and --poke is applied: only then are its
 * path printed ("P <path>") and the link made, so that a host never talks to a half-made board. */
static int announce(void)
{
	if (link_path && make_link(uart.pty.slavename) != 0)
		return -1;
	fprintf(exchange_out, "P %s\n", uart.pty.slavename);
	fflush(exchange_out);
	return 0;
}

static double seconds_since(const struct timespec *start)
{
	struct timespec now;
	clock_gettime(CLOCK_MONOTONIC, &now);
	return (now.tv_sec - start->tv_sec) + (now.tv_nsec - start->tv_nsec) * 1e-9;
}

/* Every simulated millisecond: wait for wall time to catch up, then trade PWMs for counts. */
static avr_cycle_count_t millisecond(avr_t *a, avr_cycle_count_t when, void *param)
{
	(void)param;
	double simulated_s = (double)simulated_cycles() / CPU_HZ;
	static int announced; /* once: a reset boots the board with its counts at 0 */
	if (!announced && a->cycle >= 2 * EXCHANGE_CYCLES) {
		announced = 1;
		for (int i = 0; i < poke_count; i++)
			write_variable(&pokes[i]);
		if (announce() != 0) {
			stop_requested = 1;
			return 0;
		}
	}
	if (!fast) {
		double ahead_s = simulated_s - seconds_since(&wall_start);
		if (-ahead_s > most_behind_s)
			most_behind_s = -ahead_s;
		if (ahead_s > 0) {
			struct timespec pause = {0, (long)(ahead_s * 1e9)};
			nanosleep(&pause, NULL);
		}
	}
	if (exchange) {
		int left = pwm_of(&LEFT_FORWARD) - pwm_of(&LEFT_BACKWARD);
		int right = pwm_of(&RIGHT_FORWARD) - pwm_of(&RIGHT_BACKWARD);
		fprintf(exchange_out, "D %llu %d %d",
			(unsigned long long)(simulated_cycles() / (CPU_HZ / 1000000)), left, right);
		for (int i = 0; i < watch_count; i++)
			fprintf(exchange_out, " %lu", read_variable(&watches[i]));
		if (timing)
			fprintf(exchange_out, " %llu", (unsigned long long)timed_last);
		fputc('\n', exchange_out);
		fflush(exchange_out);
		long counts[2];
		if (scanf("%ld %ld", &counts[0], &counts[1]) != 2) {
			stop_requested = 1;
			return 0;
		}
		for (int i = 0; i < 2; i++) {
			encoder_t *enc = &encoders[i];
			long steps = labs(counts[i] - enc->shown);
			enc->target = counts[i];
			avr_cycle_timer_cancel(a, encoder_edge, enc);
			if (steps == 0)
				continue;
			/* Evenly spread; at least 100 cycles apart so that each pin-change interrupt has run
			 * before the next edge (two edges in one interrupt would count as none). */
			enc->interval = EXCHANGE_CYCLES / (avr_cycle_count_t)steps;
			if (enc->interval < 100)
				enc->interval = 100;
			avr_cycle_timer_register(a, enc->interval / 2, encoder_edge, enc);
		}
	}
	return when + EXCHANGE_CYCLES;
}

static void on_signal(int signum)
{
	if (signum == SIGUSR1)
		reset_requested = 1;
	else
		stop_requested = 1;
}

/* Reset the MCU as DTR does, keeping the UART's pty, the encoders' pins and simulated time. */
static void reset_board(void)
{
	avr_cycle_count_t before = avr->cycle;
	avr_reset(avr);
	/* avr_reset clears the cycle timers; whether it also zeroes the cycle counter depends on the
	 * simavr version, so carry the time over only when it did. */
	if (avr->cycle < before)
		cycles_before_resets += before - avr->cycle;
	for (int i = 0; i < 2; i++) {
		avr_cycle_timer_cancel(avr, encoder_edge, &encoders[i]);
		encoders[i].target = encoders[i].shown;
		show_encoder(&encoders[i]);
	}
	avr_cycle_timer_cancel(avr, millisecond, NULL);
	timed_return = 0;
	avr_cycle_timer_register(avr, EXCHANGE_CYCLES - avr->cycle % EXCHANGE_CYCLES, millisecond, NULL);
}

/* Point link_path at the pty, replacing any old link atomically. */
static int make_link(const char *target)
{
	char temporary[4096];
	snprintf(temporary, sizeof temporary, "%s.%d.tmp", link_path, (int)getpid());
	unlink(temporary);
	if (symlink(target, temporary) != 0 || rename(temporary, link_path) != 0) {
		fprintf(stderr, "avr_board: cannot link %s: %s\n", link_path, strerror(errno));
		return -1;
	}
	return 0;
}

int main(int argc, char **argv)
{
	const char *elf_path = NULL;
	for (int i = 1; i < argc; i++) {
		if (!strcmp(argv[i], "--link") && i + 1 < argc)
			link_path = argv[++i];
		else if (!strcmp(argv[i], "--exchange"))
			exchange = 1;
		else if (!strcmp(argv[i], "--fast"))
			fast = 1;
		else if (!strcmp(argv[i], "--watch") && i + 1 < argc && watch_count < MAX_VARIABLES &&
			 parse_variable(argv[i + 1], &watches[watch_count], 0))
			watch_count++, i++;
		else if (!strcmp(argv[i], "--poke") && i + 1 < argc && poke_count < MAX_VARIABLES &&
			 parse_variable(argv[i + 1], &pokes[poke_count], 1))
			poke_count++, i++;
		else if (!strcmp(argv[i], "--time-function") && i + 1 < argc) {
			char *end;
			timed_entry = strtoul(argv[++i], &end, 0);
			if (*end != 0 || timed_entry == 0) {
				fprintf(stderr, USAGE);
				return 2;
			}
			timing = 1;
		} else if (argv[i][0] != '-' && !elf_path)
			elf_path = argv[i];
		else {
			fprintf(stderr, USAGE);
			return 2;
		}
	}
	if (!elf_path) {
		fprintf(stderr, USAGE);
		return 2;
	}
	/* Our lines go to the real stdout; simavr's and uart_pty's notes go to stderr. */
	exchange_out = fdopen(dup(STDOUT_FILENO), "w");
	dup2(STDERR_FILENO, STDOUT_FILENO);

	elf_firmware_t firmware = {0};
	if (elf_read_firmware(elf_path, &firmware) != 0) {
		fprintf(stderr, "avr_board: cannot read %s\n", elf_path);
		return 1;
	}
	avr = avr_make_mcu_by_name("atmega328p");
	if (!avr) {
		fprintf(stderr, "avr_board: simavr has no atmega328p\n");
		return 1;
	}
	avr_init(avr);
	avr_load_firmware(avr, &firmware);
	avr->frequency = CPU_HZ;
	/* Not LOG_WARNING: simavr warns at every OCR1x write in the Arduino core's timer-1 set-up
	 * (8-bit phase-correct PWM), which it does not model; the OCRs are read here directly. */
	avr->log = LOG_ERROR;

	/* uart_pty's reader thread inherits this mask: a signal it took would end its select() loop
	 * and leave the board deaf, so only this thread takes them. */
	sigset_t handled, previous;
	sigemptyset(&handled);
	sigaddset(&handled, SIGINT);
	sigaddset(&handled, SIGTERM);
	sigaddset(&handled, SIGHUP);
	sigaddset(&handled, SIGUSR1);
	pthread_sigmask(SIG_BLOCK, &handled, &previous);
	uart_pty_init(avr, &uart);
	pthread_sigmask(SIG_SETMASK, &previous, NULL);
	uart_pty_connect(&uart, '0');
	/* The firmware enables the pull-ups: the encoder pins read high until the encoder drives
	 * them; state 0 of the Gray sequence is (0, 0), so show it from the start. */
	for (int i = 0; i < 2; i++)
		show_encoder(&encoders[i]);


	struct sigaction action = {0};
	action.sa_handler = on_signal;
	sigaction(SIGINT, &action, NULL);
	sigaction(SIGTERM, &action, NULL);
	sigaction(SIGHUP, &action, NULL);
	/* A reset must not interrupt the wait for the motor model's answer: an EINTR there would
	 * read as the end of the exchange and stop the simulator. */
	action.sa_flags = SA_RESTART;
	sigaction(SIGUSR1, &action, NULL);
	signal(SIGPIPE, SIG_IGN);

	clock_gettime(CLOCK_MONOTONIC, &wall_start);
	avr_cycle_timer_register(avr, EXCHANGE_CYCLES, millisecond, NULL);
	int state = cpu_Running;
	while (!stop_requested && state != cpu_Done && state != cpu_Crashed) {
		if (reset_requested) {
			reset_requested = 0;
			reset_board();
		}
		state = avr_run(avr);
		if (timing)
			time_function();
	}
	if (link_path)
		unlink(link_path);
	fprintf(stderr, "avr_board: %.3f s simulated in %.3f s, at most %.0f ms behind\n",
		(double)simulated_cycles() / CPU_HZ, seconds_since(&wall_start), most_behind_s * 1e3);
	if (timing)
		fprintf(stderr, "avr_board: timed function: %lu calls, cycles least %llu mean %.0f most %llu\n",
			timed_calls, (unsigned long long)timed_least,
			timed_calls ? (double)timed_total / timed_calls : 0.0,
			(unsigned long long)timed_most);
	/* Not uart_pty_stop(): joining its reader thread can block; the process ends it. */
	fflush(exchange_out);
	_exit(state == cpu_Crashed ? 1 : 0);
}
