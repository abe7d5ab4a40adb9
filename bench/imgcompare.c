/* imgcompare: PSNR and SSIM between two 8-bit binary PNM images.
 *
 * usage: imgcompare REFERENCE.ppm TEST.ppm
 *
 * Both files are binary PPM (P6) or PGM (P5) with maxval 255 and the same
 * width and height. A gray image compared with an RGB one is expanded to RGB
 * by repeating its channel.
 *
 * Output, one line:
 *     psnr=XX.XXX ssim=0.XXXX
 *
 * psnr   over RGB: 10*log10(255^2 / MSE), MSE being the mean squared error
 *        over every sample (3 per pixel) of the image. For two gray images it
 *        is the same figure as over the one channel. "inf" for identical
 *        images.
 * ssim   mean SSIM (Wang, Bovik, Sheikh, Simoncelli 2004) of luma
 *        Y = 0.299 R + 0.587 G + 0.114 B (BT.601, full range, not rounded),
 *        with the standard 11x11 Gaussian window (sigma 1.5), K1 = 0.01,
 *        K2 = 0.03, L = 255, averaged over every window that lies wholly inside
 *        the image (no padding, no downsampling).
 *
 * Build: cc -std=c11 -O2 -Wall -Wextra -o imgcompare imgcompare.c -lm
 */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdint.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>

struct pnm {
	size_t w, h;
	int channels;          /* 1 or 3 */
	unsigned char *data;   /* w * h * channels bytes */
};

__attribute__((format(printf, 1, 2), noreturn))
static void die(const char *fmt, ...)
{
	va_list ap;
	va_start(ap, fmt);
	fprintf(stderr, "imgcompare: ");
	vfprintf(stderr, fmt, ap);
	fputc('\n', stderr);
	va_end(ap);
	exit(2);
}

/* Reads one unsigned decimal header field, skipping blanks and comments. */
static int read_field(FILE *f, size_t *out)
{
	int c;
	for (;;) {
		c = getc(f);
		if (c == '#') {
			while (c != '\n' && c != EOF)
				c = getc(f);
		} else if (c == ' ' || c == '\t' || c == '\n' || c == '\r') {
			continue;
		} else {
			break;
		}
	}
	if (c < '0' || c > '9')
		return -1;
	size_t v = 0;
	while (c >= '0' && c <= '9') {
		if (v > (SIZE_MAX - 9) / 10)
			return -1;
		v = v * 10 + (size_t)(c - '0');
		c = getc(f);
	}
	/* exactly one whitespace byte ends the field; keep it consumed */
	if (c != ' ' && c != '\t' && c != '\n' && c != '\r')
		return -1;
	*out = v;
	return 0;
}

static void pnm_read(const char *path, struct pnm *img)
{
	FILE *f = fopen(path, "rb");
	if (!f)
		die("cannot open %s", path);
	char magic[2];
	if (fread(magic, 1, 2, f) != 2 || magic[0] != 'P' ||
	    (magic[1] != '5' && magic[1] != '6'))
		die("%s: not a binary PPM/PGM (P6/P5)", path);
	img->channels = magic[1] == '6' ? 3 : 1;
	size_t maxval;
	if (read_field(f, &img->w) || read_field(f, &img->h) ||
	    read_field(f, &maxval))
		die("%s: bad PNM header", path);
	if (maxval != 255)
		die("%s: only maxval 255 (8-bit) is supported", path);
	if (img->w == 0 || img->h == 0 || img->w > (1u << 20) ||
	    img->h > (1u << 20) ||
	    img->w > SIZE_MAX / img->h / 3)
		die("%s: unsupported dimensions", path);
	size_t n = img->w * img->h * (size_t)img->channels;
	img->data = malloc(n);
	if (!img->data)
		die("%s: out of memory", path);
	if (fread(img->data, 1, n, f) != n)
		die("%s: truncated pixel data", path);
	fclose(f);
}

static double sample(const struct pnm *img, size_t i, int c)
{
	return img->channels == 3 ? img->data[i * 3 + (size_t)c] : img->data[i];
}

static double luma(const struct pnm *img, size_t i)
{
	if (img->channels == 1)
		return img->data[i];
	const unsigned char *p = img->data + i * 3;
	return 0.299 * p[0] + 0.587 * p[1] + 0.114 * p[2];
}

static double psnr_rgb(const struct pnm *a, const struct pnm *b)
{
	size_t n = a->w * a->h;
	int ch = (a->channels == 3 || b->channels == 3) ? 3 : 1;
	double sse = 0;
	for (size_t i = 0; i < n; i++)
		for (int c = 0; c < ch; c++) {
			double d = sample(a, i, c) - sample(b, i, c);
			sse += d * d;
		}
	double mse = sse / ((double)n * ch);
	if (mse == 0)
		return INFINITY;
	return 10.0 * log10(255.0 * 255.0 / mse);
}

#define WIN 11
#define RAD (WIN / 2)

/* Mean SSIM of luma, 11x11 Gaussian window (sigma 1.5), valid region. */
static double ssim_y(const struct pnm *a, const struct pnm *b)
{
	size_t w = a->w, h = a->h;
	if (w < WIN || h < WIN)
		return NAN;
	double g[WIN], gs = 0;
	for (int k = 0; k < WIN; k++) {
		double x = k - RAD;
		g[k] = exp(-x * x / (2 * 1.5 * 1.5));
		gs += g[k];
	}
	for (int k = 0; k < WIN; k++)
		g[k] /= gs;

	const double C1 = (0.01 * 255) * (0.01 * 255);
	const double C2 = (0.03 * 255) * (0.03 * 255);
	size_t ow = w - (WIN - 1), oh = h - (WIN - 1);

	/* Horizontal pass into a ring of WIN rows for the five moments, then a
	 * vertical pass per output row: memory is O(w), not O(w*h). */
	double *ya = malloc(w * sizeof *ya), *yb = malloc(w * sizeof *yb);
	double *ring = malloc((size_t)WIN * 5 * ow * sizeof *ring);
	if (!ya || !yb || !ring)
		die("%s", "out of memory");

	double total = 0;
	for (size_t y = 0; y < h; y++) {
		for (size_t x = 0; x < w; x++) {
			ya[x] = luma(a, y * w + x);
			yb[x] = luma(b, y * w + x);
		}
		double *r = ring + (y % WIN) * 5 * ow;
		for (size_t x = 0; x < ow; x++) {
			double s1 = 0, s2 = 0, s11 = 0, s22 = 0, s12 = 0;
			for (int k = 0; k < WIN; k++) {
				double p = ya[x + (size_t)k], q = yb[x + (size_t)k];
				s1 += g[k] * p;
				s2 += g[k] * q;
				s11 += g[k] * p * p;
				s22 += g[k] * q * q;
				s12 += g[k] * p * q;
			}
			r[x] = s1;
			r[ow + x] = s2;
			r[2 * ow + x] = s11;
			r[3 * ow + x] = s22;
			r[4 * ow + x] = s12;
		}
		if (y + 1 < WIN)
			continue;
		size_t top = y + 1 - WIN;
		for (size_t x = 0; x < ow; x++) {
			double m[5] = { 0, 0, 0, 0, 0 };
			for (int k = 0; k < WIN; k++) {
				const double *rr = ring + ((top + (size_t)k) % WIN) * 5 * ow;
				for (int j = 0; j < 5; j++)
					m[j] += g[k] * rr[(size_t)j * ow + x];
			}
			double mu1 = m[0], mu2 = m[1];
			double v1 = m[2] - mu1 * mu1, v2 = m[3] - mu2 * mu2;
			double cv = m[4] - mu1 * mu2;
			total += ((2 * mu1 * mu2 + C1) * (2 * cv + C2)) /
				 ((mu1 * mu1 + mu2 * mu2 + C1) * (v1 + v2 + C2));
		}
	}
	free(ya);
	free(yb);
	free(ring);
	return total / ((double)ow * (double)oh);
}

int main(int argc, char **argv)
{
	if (argc != 3) {
		fprintf(stderr, "usage: imgcompare REFERENCE.ppm TEST.ppm\n"
				"prints: psnr=<dB, RGB, from total MSE> "
				"ssim=<mean SSIM of BT.601 luma, 11x11 Gaussian "
				"window, sigma 1.5>\n");
		return 2;
	}
	struct pnm a, b;
	pnm_read(argv[1], &a);
	pnm_read(argv[2], &b);
	if (a.w != b.w || a.h != b.h) {
		fprintf(stderr, "imgcompare: size mismatch: %zux%zu vs %zux%zu\n",
			a.w, a.h, b.w, b.h);
		return 2;
	}
	double p = psnr_rgb(&a, &b);
	double s = ssim_y(&a, &b);
	if (isinf(p))
		printf("psnr=inf ssim=%.4f\n", s);
	else
		printf("psnr=%.3f ssim=%.4f\n", p, s);
	free(a.data);
	free(b.data);
	return 0;
}
