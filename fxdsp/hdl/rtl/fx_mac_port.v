// fx_mac_port: a serial block's multiplier, its own or an external shared one (chain_paper002
// ARCH = 1 runs every serial block's products through ONE fx_mac_serial: the blocks run one after
// another, so they never multiply at the same time).
// Caller side: the ports of fx_mac_serial (in_valid / in_ready, a, b, out_valid, p = a * b exact in
// A_W + B_W bits, valid in the out_valid cycle), the caller's own widths.
// EXT_MAC = 0: an fx_mac_serial of the caller's widths (VAR_N: fx_mac_serial's, na, nb read only
//   when 1); the bundle outputs are 0 and its inputs are not read.
// EXT_MAC = 1: no multiplier here; the request goes out on the bundle: mac_in_valid = in_valid,
//   in_ready = mac_in_ready, mac_a / mac_b = a / b sign-extended to MAC_A_W / MAC_B_W, mac_na /
//   mac_nb = the product's limb counts (VAR_N = 1: na, nb; else ceil(A_W / 16), ceil(B_W / 16), the
//   caller's own schedule: N = their product, latency N + 3), out_valid = mac_out_valid, p = the low
//   A_W + B_W bits of the top 16 (NA + NB) bits of mac_p (the caller's limbs NA, NB: the shared
//   fx_mac_serial, VAR_N = 1, returns the product top-aligned in whole limbs; the bits below and the
//   window's sign copies are not the caller's). With VAR_N = 1 (A_W, B_W whole limbs) p is that
//   top-aligned window itself, passed on to the callers behind this port.
// No arithmetic here: rounding none (no floor / half_up / half_even / toward_zero; the caller rounds
// with fx_round), overflow none (no wrap / saturate: p holds every product exactly).
`default_nettype none

module fx_mac_port #(
    parameter integer A_W     = 32,   // the caller's operand a (signed bits, >= 2)
    parameter integer B_W     = 24,   // the caller's operand b
    parameter integer VAR_N   = 0,    // 1: the caller gives the limb counts na, nb per product
    parameter integer EXT_MAC = 0,    // 0: own fx_mac_serial; 1: the external multiplier on the bundle
    parameter integer MAC_A_W = 48,   // EXT_MAC = 1: the bundle's operand widths (>= A_W, B_W)
    parameter integer MAC_B_W = 32    // (3 x 2 limbs by default)
) (
    input  wire                          clk,
    input  wire                          rst,
    input  wire                          in_valid,
    output wire                          in_ready,
    input  wire signed [A_W-1:0]         a,
    input  wire signed [B_W-1:0]         b,
    /* verilator lint_off UNUSEDSIGNAL */   // VAR_N = 0: not read
    input  wire [3:0]                    na,
    input  wire [3:0]                    nb,
    /* verilator lint_on UNUSEDSIGNAL */
    output wire                          out_valid,
    output wire signed [A_W+B_W-1:0]     p,
    // the external multiplier (EXT_MAC = 1)
    output wire                          mac_in_valid,
    input  wire                          mac_in_ready,
    output wire [MAC_A_W-1:0]            mac_a,
    output wire [MAC_B_W-1:0]            mac_b,
    output wire [3:0]                    mac_na,
    output wire [3:0]                    mac_nb,
    input  wire                          mac_out_valid,
    input  wire [MAC_A_W+MAC_B_W-1:0]    mac_p
);
    localparam integer P_W  = A_W + B_W;
    localparam integer MP_W = MAC_A_W + MAC_B_W;
    localparam integer LIMB = 16;                  // fx_mac_serial's limb
    localparam integer A_UP = A_W + LIMB - 1;
    localparam integer B_UP = B_W + LIMB - 1;
    localparam integer NA_I = A_UP / LIMB;         // the caller's limbs (fx_mac_serial's NA, NB)
    localparam integer NB_I = B_UP / LIMB;
    localparam [3:0]   NA_C = NA_I[3:0];
    localparam [3:0]   NB_C = NB_I[3:0];

    generate
        if (EXT_MAC == 0) begin : g_own
            fx_mac_serial #(.A_W(A_W), .B_W(B_W), .VAR_N(VAR_N)) u_mac (.clk(clk), .rst(rst), .in_valid(in_valid),
                .in_ready(in_ready), .a(a), .b(b), .na(na), .nb(nb), .out_valid(out_valid), .p(p));
            assign mac_in_valid = 1'b0;
            assign mac_a  = {MAC_A_W{1'b0}};
            assign mac_b  = {MAC_B_W{1'b0}};
            assign mac_na = 4'd0;
            assign mac_nb = 4'd0;
            /* verilator lint_off UNUSEDSIGNAL */
            wire unused_bundle = mac_in_ready ^ mac_out_valid ^ (^mac_p);
            /* verilator lint_on UNUSEDSIGNAL */
        end else begin : g_ext
            if (A_W > MAC_A_W || B_W > MAC_B_W) begin : g_bad_width
                initial begin $display("fx_mac_port: operands %0d x %0d exceed the external multiplier's %0d x %0d",
                                       A_W, B_W, MAC_A_W, MAC_B_W); $finish; end
            end
            /* verilator lint_off UNUSEDSIGNAL */
            wire unused_clk_rst = rst ^ clk;   // no multiplier here: no clock, no reset
            /* verilator lint_on UNUSEDSIGNAL */
            assign mac_in_valid = in_valid;
            assign in_ready     = mac_in_ready;
            assign mac_a  = {{(MAC_A_W-A_W+1){a[A_W-1]}}, a[A_W-2:0]};
            assign mac_b  = {{(MAC_B_W-B_W+1){b[B_W-1]}}, b[B_W-2:0]};
            assign mac_na = (VAR_N != 0) ? na : NA_C;
            assign mac_nb = (VAR_N != 0) ? nb : NB_C;
            assign out_valid = mac_out_valid;
            // the caller's window: the top WIN = 16 (NA + NB) bits of mac_p; its product in the low P_W
            localparam integer WIN   = LIMB * (NA_I + NB_I);
            localparam integer BELOW = MP_W - WIN;
            if (WIN > MP_W) begin : g_bad_window
                initial begin $display("fx_mac_port: %0d limbs exceed the external multiplier's %0d bits",
                                       NA_I + NB_I, MP_W); $finish; end
            end
            /* verilator lint_off UNUSEDSIGNAL */   // not the caller's product (see above)
            wire [WIN-1:0] win;
            /* verilator lint_on UNUSEDSIGNAL */
            if (BELOW > 0) begin : g_below
                /* verilator lint_off UNUSEDSIGNAL */
                wire [BELOW-1:0] p_below;
                /* verilator lint_on UNUSEDSIGNAL */
                assign {win, p_below} = mac_p;
            end else begin : g_whole
                assign win = mac_p;
            end
            if (WIN > P_W) begin : g_cut
                /* verilator lint_off UNUSEDSIGNAL */   // the window's sign copies
                wire [WIN-P_W-1:0] p_above;
                /* verilator lint_on UNUSEDSIGNAL */
                assign {p_above, p} = win;
            end else begin : g_all
                assign p = win;
            end
        end
    endgenerate
endmodule

`default_nettype wire
